"""The settings of one run, resolved in one place: defaults < ``--quick`` < ``--set``.

:func:`resolve` turns a study, ``--quick`` and the ``--set`` items into validated
:class:`Resolved` settings: the scalar settings, the swept ones (outer axes of the cube), the
``solver.Params`` of the physical settings and the study's grid axes (with any new values a
``--set`` gave them). Everything is checked here, before any work starts (what each setting
allows: ``study.setting_table``, read by ``study.checks``); every problem is a one-line
:class:`~rimroll.study.registry.UserError`.

``--set`` words are split by ``study.cli_text`` (``--set mu=0.5,1,2`` is one key with a list,
``--set mu=1,v_throw=2`` two keys). A value is ``KEY=0.5`` (a scalar, converted to the type of
the setting's default), ``KEY=0.5,1,2`` (a list, in the order given) or ``KEY=start:stop:num``
(``num >= 2`` points of an inclusive linspace). A list or range is allowed for the study's ``sweepable`` settings
(outer axes, in the study's order, then in the order of ``--set``) and for the names of its grid
axes (new grid values). The physical keys (r R a m j mu g k_r k_d c_r c_d rho_air C_D, SI units) and ``rho_over_R``
build a :class:`solver.Params`; a set of them Params refuses (rho >= R, ...) gives Params'
ValueError message as the error.
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Iterable

import numpy as np

from rimroll import solver
from rimroll.study import checks
from rimroll.study.registry import PHYSICAL_KEYS, Axis, Study, UserError
from rimroll.study.setting_table import lookup


@dataclasses.dataclass(frozen=True)
class Resolved:
    """The validated settings of one run."""

    settings: dict  # every setting; a swept key holds its tuple of values
    params: solver.Params  # of the scalar settings, every swept key at its first value
    outer: tuple  # one Axis per swept setting, in cube order
    grid: tuple  # the study's grid axes, with the values given by --set AXIS=list|range


def resolve(study: Study, quick: bool = False, values=None) -> Resolved:
    """Resolve and check the settings of ``study``: defaults < ``quick`` < ``values`` (``{key: value}``:
    a number, a label, a switch, or a list, tuple, range or numpy array of several: a sweep)."""
    settings, order, grid_values = _apply(study, quick, values)
    base = base_settings(settings)
    checks.check_settings(study.name, settings)
    outer = _outer_axes(settings, order)
    params = params_from(base)
    if study.check is not None:  # derived quantities (a model's parameters from a strength), every swept value
        try:
            study.check(settings, params)
        except ValueError as exc:
            raise UserError(f"settings of {study.name!r}: {' '.join(str(exc).split())}") from None
    grid = _regrid(study, grid_axes(study, base), grid_values)
    names = [a.name for a in outer] + [a.name for a in grid]
    if len(set(names)) != len(names):
        raise UserError(f"study {study.name!r}: a swept setting has the name of a grid axis: {names}")
    return Resolved(settings, params, tuple(outer), tuple(grid))


def default_settings(study: Study) -> dict:
    """The study's settings plus every physical parameter at its Table 1 value."""
    out = solver.Params().as_dict()
    out.update(study.settings)
    return out


def base_settings(settings: dict) -> dict:
    """Settings with every swept key at its first value (what the grid axes are built from)."""
    return {k: (v[0] if isinstance(v, tuple) else v) for k, v in settings.items()}


def params_from(settings: dict) -> solver.Params:
    """Params of scalar settings; ``rho_over_R`` (if not None) fixes r = rho_over_R * R - a."""
    physical = {k: settings[k] for k in PHYSICAL_KEYS}
    x = settings.get("rho_over_R")
    try:
        if x is None:
            return solver.Params(**physical)
        physical.pop("r")
        return solver.Params.from_rho_over_R(float(x), **physical)
    except ValueError as exc:
        raise UserError(str(exc)) from None


def grid_axes(study: Study, settings: dict) -> list[Axis]:
    """The study's axes for these scalar settings; invalid ones become a :class:`UserError`."""
    try:
        axes = list(study.axes(settings))
    except ValueError as exc:
        raise UserError(f"settings give invalid axes for {study.name!r}: {exc}") from None
    if len({a.name for a in axes}) != len(axes):
        raise ValueError(f"study {study.name!r} declares duplicate axis names")
    return axes


# ------------------------------------------------------------------ values of a run


def _items(key: str, value) -> list:
    """The items of a list-like value (a list, tuple, range, numpy array, generator), read once (a
    generator is consumed here only) and at most :data:`checks.MAX_AXIS` of them: UserError naming the
    size and the limit before anything else is done with them."""
    if isinstance(value, np.ndarray):
        if value.size > checks.MAX_AXIS:
            raise UserError(f"setting {key}: {value.size} values; at most {checks.MAX_AXIS} per swept setting")
        return value.tolist() if value.ndim else [value.item()]
    items = []
    for item in value:
        if len(items) == checks.MAX_AXIS:
            raise UserError(f"setting {key}: more than {checks.MAX_AXIS} values; at most {checks.MAX_AXIS} per "
                            "swept setting")
        items.append(item)
    return items


def _shown(value) -> str:
    """A value as an error message shows it: a list as ``a,b,c``, a number or label as itself."""
    if isinstance(value, tuple):
        return ",".join(_shown(v) for v in value)
    if isinstance(value, (bool, np.bool_)):
        return str(bool(value)).lower()
    if isinstance(value, (float, np.floating)) and np.isfinite(value):  # the shorter of 1e+12 and 1000000000000.0
        science = np.format_float_scientific(value, unique=True, trim="-").replace("e+", "e")
        return min(repr(float(value)), science, key=len)
    return str(value)


def _shape(key: str, value):
    """A value given for ``key`` as a scalar (number, label, switch) or a tuple of them (a list, tuple,
    range, numpy array or other iterable of several; one item is a scalar). UserError for an empty or
    nested list or for what is neither."""
    if isinstance(value, (str, bool, np.bool_, int, float, np.integer, np.floating)):
        return value
    if isinstance(value, (bytes, dict)) or not isinstance(value, Iterable):
        raise UserError(f"setting {key}={value!r}: expected a number, a label, a list or a range")
    items = _items(key, value)
    if any(not isinstance(v, str) and isinstance(v, Iterable) for v in items):
        raise UserError(f"setting {key}={items!r}: a list of values must be flat (one axis), not nested")
    if not items:
        raise UserError(f"setting {key}=[]: an empty list; give one value or several")
    items = [_shape(key, v) for v in items]
    return items[0] if len(items) == 1 else tuple(items)


def _typed(key: str, value, default):
    """A scalar ``value`` as the type of ``default``: a number (float; an int or a numpy number too), an
    integer, a switch (True/False, or 1/0), a label (str); a one-line UserError otherwise."""
    switch = isinstance(value, (bool, np.bool_))
    numeric = isinstance(value, (int, float, np.integer, np.floating)) and not switch
    if isinstance(default, bool):
        if switch or (numeric and value in (0, 1)):
            return bool(value)
        kind = "true/false"
    elif isinstance(default, int):
        if isinstance(value, (int, np.integer)) and not switch:
            return int(value)
        kind = "an integer"
    elif isinstance(default, str):
        if isinstance(value, str):
            return value
        entry = lookup(key)
        kind = f"one of {', '.join(entry.labels())}" if entry.choices is not None else "a label (text)"
    else:
        if numeric:
            return float(value)
        kind = "a number" + (" (a range is a list or numpy.linspace(start, stop, num), not text)"
                             if isinstance(value, str) and ":" in value else "")
    raise UserError(f"setting {key}={_shown(value)}: expected {kind}")


def _apply(study: Study, quick: bool, values) -> tuple[dict, list[str], dict]:
    """(settings, swept keys in axis order, grid overrides ``{axis: values}``).

    A swept key's setting holds its tuple of values. Defaults < ``quick`` < ``values``.
    """
    settings = default_settings(study)
    for key in study.sweepable:
        settings.setdefault(key, None)
    if quick:
        settings.update(study.quick)
    declared = dict.fromkeys([*study.settings, *(study.quick if quick else ())])
    order = [k for k in declared if isinstance(settings[k], (tuple, list))]
    grid_names = {a.name for a in grid_axes(study, base_settings(settings))}
    values = dict(values or {})
    if not all(isinstance(key, str) for key in values):
        raise UserError(f"settings of {study.name!r}: every key must be a setting's name (str)")
    grid = {}
    for key, value in values.items():
        value = _shape(key, value)
        entry = lookup(key)
        switch = isinstance(settings.get(key), bool)
        if (entry.choices is not None or switch) and isinstance(value, tuple) and key not in study.sweepable:
            allowed = "true or false" if switch else f"one of {', '.join(entry.labels())}"
            raise UserError(f"setting {key}={_shown(value)}: {key} takes {allowed}, not a list or range (it cannot be "
                            f"swept in study {study.name!r})")
        if key in grid_names and f"n_{key}" in values:
            raise UserError(f"setting {key}={_shown(value)} and setting n_{key}: give the {key} axis either as values "
                            f"or as a number of points, not both")
        if isinstance(value, tuple) and key in grid_names:
            grid[key] = tuple(_typed(key, v, 1.0) for v in value)
            continue
        if key in study.ignores:
            raise UserError(f"setting {key}={_shown(value)}: study {study.name!r} does not use {key!r} "
                            f"({study.ignores[key]})")
        if key not in settings:
            raise UserError(f"unknown setting {key!r} for study {study.name!r}; "
                            f"known: {', '.join(sorted(k for k in settings if k not in study.ignores))}")
        default = settings[key]
        if default is None or isinstance(default, (tuple, list)) or (entry.sweep and entry.choices is None):
            default = entry.labels()[0] if entry.choices is not None else 1.0  # a swept setting's kind
        if not isinstance(value, tuple):
            settings[key] = _typed(key, value, default)
            if key in order:
                order.remove(key)
        elif key in study.sweepable:
            settings[key] = tuple(_typed(key, v, default) for v in value)
            if key not in order:
                order.append(key)
        else:
            sweepable = ", ".join(study.sweepable) or "none"
            raise UserError(f"setting {key}={_shown(value)}: {key!r} cannot be swept in study {study.name!r} "
                            f"(sweepable: {sweepable}; or a grid axis: {', '.join(sorted(grid_names))})")
    settings = {k: (tuple(x if isinstance(x, str) else float(x) for x in v) if isinstance(v, (tuple, list)) else v)
                for k, v in settings.items()}
    return settings, order, grid


def _outer_axes(settings: dict, order: list[str]) -> list[Axis]:
    """The outer axes of the swept keys (units and long_name from the setting table), each
    physical value validated in the Params of the other settings at base."""
    base = base_settings(settings)
    axes = []
    for key in order:
        values = settings[key]
        if key in PHYSICAL_KEYS or key == "rho_over_R":
            for v in values:
                params_from({**base, key: v})  # Params' checks of the whole set (rho < R, r > 0)
        setting = lookup(key)
        units, long_name = setting.units, setting.axis_long_name
        allow_inf = setting.range is not None and setting.range.contains(math.inf)  # mu only (setting table)
        try:
            axes.append(Axis(key, np.array(values), units, long_name, allow_inf=allow_inf,
                             comment=setting.doc if setting.doc != long_name else ""))
        except ValueError as exc:
            raise UserError(f"setting {key}: {exc}") from None
    return axes


def _regrid(study: Study, axes: list[Axis], grid: dict) -> list[Axis]:
    """Grid axes with the values given by ``--set AXIS=list|range`` (checked like a setting of
    that name: the setting table's range, else finite and of bounded magnitude)."""
    out = []
    for a in axes:
        if a.name in grid:
            checks.check_values(study.name, a.name, grid[a.name], "grid value")
            if a.aux:
                raise UserError(f"setting {a.name}: axis {a.name!r} carries auxiliary coordinates and "
                                "cannot be given new values")
            try:
                a = Axis(a.name, np.array(grid[a.name]), a.units, a.long_name)
            except ValueError as exc:
                raise UserError(f"setting {a.name}: {exc}") from None
        out.append(a)
    return out
