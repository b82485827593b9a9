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

import numpy as np

from rimroll import solver
from rimroll.study import checks, cli_text
from rimroll.study.registry import PHYSICAL_KEYS, Axis, Study, UserError
from rimroll.study.setting_table import lookup


@dataclasses.dataclass(frozen=True)
class Resolved:
    """The validated settings of one run."""

    settings: dict  # every setting; a swept key holds its tuple of values
    params: solver.Params  # of the scalar settings, every swept key at its first value
    outer: tuple  # one Axis per swept setting, in cube order
    grid: tuple  # the study's grid axes, with the values given by --set AXIS=list|range


def resolve(study: Study, quick: bool = False, sets=()) -> Resolved:
    """Resolve and check the settings of ``study``: defaults < ``quick`` < ``--set`` items."""
    settings, order, grid_values = _apply(study, quick, sets)
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


# ------------------------------------------------------------------ --set items


def parse_values(key: str, text: str):
    """A tuple of floats for a list or range, else ``None`` (the text is a scalar).

    At most :data:`rimroll.study.checks.MAX_AXIS` values."""
    if ":" in text:
        parts = text.split(":")
        if len(parts) != 3:
            raise UserError(f"setting {key}={text}: a range is start:stop:num, e.g. {key}=0.4:0.6:5")
        start, stop = _float(key, parts[0]), _float(key, parts[1])
        try:
            num = integer(parts[2])
        except ValueError:
            raise UserError(f"setting {key}={text}: num of start:stop:num must be an integer") from None
        if num < 2:
            raise UserError(f"setting {key}={text}: a range needs num >= 2 points (give one value as a scalar)")
        if num > checks.MAX_AXIS:
            raise UserError(f"setting {key}={text}: at most {checks.MAX_AXIS} values per swept setting; got {num}")
        if not (math.isfinite(start) and math.isfinite(stop)) or start == stop:
            raise UserError(f"setting {key}={text}: a range needs finite start != stop")
        with np.errstate(over="ignore", invalid="ignore"):  # stop - start beyond the largest float
            values = np.linspace(start, stop, num)
        if not np.all(np.isfinite(values)):
            raise UserError(f"setting {key}={text}: the range's points are not finite numbers (start and stop too far "
                            "apart for a float)")
        return tuple(float(v) for v in values)
    if "," in text:
        items = [t.strip() for t in text.split(",")]
        if any(not t for t in items):
            raise UserError(f"setting {key}={text}: empty item in the list")
        if len(items) > checks.MAX_AXIS:
            raise UserError(f"setting {key}: at most {checks.MAX_AXIS} values per swept setting; got {len(items)}")
        return tuple(_float(key, t) for t in items)
    return None


def _plain(text: str) -> str:
    """``text`` if it is written in plain ASCII without '_' (Python's float() and int() also read
    full-width digits, '１', and digit groups, '1_0', which a setting should not take for 1 and 10);
    else ValueError."""
    if not text.isascii() or "_" in text:
        raise ValueError(text)
    return text


def number(text: str) -> float:
    """A number the user wrote (a setting, an option, a state): ``float`` of plain ASCII without '_'
    ('inf', '1e-3', '-2' are numbers; '１' and '1_0' are not); ValueError otherwise. Its name is the
    word argparse uses: "invalid number value"."""
    return float(_plain(text))


def integer(text: str) -> int:
    """A whole number the user wrote, as :func:`number`: "invalid integer value" for argparse."""
    return int(_plain(text))


def _float(key: str, text: str) -> float:
    try:
        return number(text)
    except ValueError:
        raise UserError(f"setting {key}={text}: expected a number") from None


def _convert(key: str, text: str, default):
    """``text`` as the type of ``default`` (physical keys are floats; 'inf' allowed)."""
    try:
        if isinstance(default, bool):
            if text.lower() in ("1", "true", "yes", "on"):
                return True
            if text.lower() in ("0", "false", "no", "off"):
                return False
            raise ValueError
        if isinstance(default, int):
            return integer(text)
        if isinstance(default, float):
            return number(text)
        return type(default)(text)
    except ValueError:
        kind = {bool: "true/false", int: "an integer", float: "a number"}.get(type(default), type(default).__name__)
        raise UserError(f"setting {key}={text}: expected {kind}") from None


def _apply(study: Study, quick: bool, sets) -> tuple[dict, list[str], dict]:
    """(settings, swept keys in axis order, grid overrides ``{axis: values}``).

    A swept key's setting holds its tuple of values. Defaults < ``quick`` < ``--set``.
    """
    settings = default_settings(study)
    for key in study.sweepable:
        settings.setdefault(key, None)
    if quick:
        settings.update(study.quick)
    declared = dict.fromkeys([*study.settings, *(study.quick if quick else ())])
    order = [k for k in declared if isinstance(settings[k], (tuple, list))]
    grid_names = {a.name for a in grid_axes(study, base_settings(settings))}
    grid = {}
    pairs = cli_text.parse(sets, "--set", "KEY=VALUE", "--set mu=0.5")
    given = [key for key, _ in pairs]
    twice = sorted({key for key in given if given.count(key) > 1})
    if twice:  # the later one would silently win: say which value is meant
        key = twice[0]
        sweep = f" (a list sweeps it: --set {key}=A,B)" if key in study.sweepable else ""
        also = " (--backend is --set backend=...)" if key == "backend" else ""
        raise UserError(f"--set {key} is given {given.count(key)} times{also}; give each setting once{sweep}")
    for key, text in pairs:
        entry = lookup(key)
        switch = isinstance(settings.get(key), bool)
        if (entry.choices is not None or switch) and ("," in text or ":" in text) and key not in study.sweepable:
            allowed = "true or false" if switch else f"one of {', '.join(entry.labels())}"
            raise UserError(f"setting {key}={text}: {key} takes {allowed}, not a list or range (it cannot be swept "
                            f"in study {study.name!r})")
        if key in grid_names and f"n_{key}" in given:
            raise UserError(f"setting {key}={text} and setting n_{key}: give the {key} axis either as values or as a "
                            f"number of points, not both")
        values = parse_values(key, text)
        if values is not None and key in grid_names:
            grid[key] = values
            continue
        if key in study.ignores:
            raise UserError(f"setting {key}={text}: study {study.name!r} does not use {key!r} "
                            f"({study.ignores[key]})")
        if key not in settings:
            raise UserError(f"unknown setting {key!r} for study {study.name!r}; "
                            f"known: {', '.join(sorted(k for k in settings if k not in study.ignores))}")
        if values is None:
            default = settings[key]
            default = 1.0 if lookup(key).sweep or isinstance(default, (tuple, list)) else default
            settings[key] = _convert(key, text, default)
            if key in order:
                order.remove(key)
        elif key in study.sweepable:
            settings[key] = values
            if key not in order:
                order.append(key)
        else:
            sweepable = ", ".join(study.sweepable) or "none"
            raise UserError(f"setting {key}={text}: {key!r} cannot be swept in study {study.name!r} "
                            f"(sweepable: {sweepable}; or a grid axis: {', '.join(sorted(grid_names))})")
    settings = {k: (tuple(float(x) for x in v) if isinstance(v, (tuple, list)) else v) for k, v in settings.items()}
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
