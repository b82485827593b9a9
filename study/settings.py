"""The settings of one run, resolved in one place: defaults < ``--quick`` < ``--set``.

:func:`resolve` turns a study, ``--quick`` and the ``--set`` items into validated
:class:`Resolved` settings: the scalar settings, the swept ones (outer axes of the cube), the
``solver.Params`` of the physical settings and the study's grid axes (with any new values a
``--set`` gave them). Everything is checked here, before any work starts; every problem is a
one-line :class:`~study.registry.UserError`.

``--set`` forms: ``KEY=0.5`` (a scalar, converted to the type of the setting's default),
``KEY=0.5,1,2`` (a list, in the order given) and ``KEY=start:stop:num`` (``num >= 2`` points of
an inclusive linspace). A list or range is allowed for the study's ``sweepable`` settings
(outer axes, in the study's order, then in the order of ``--set``) and for the names of its grid
axes (new grid values). The physical keys (r R a m j mu g k_r k_d, SI units) and ``rho_over_R``
build a :class:`solver.Params`; a bad value gives Params' ValueError message as the error.
"""

from __future__ import annotations

import dataclasses
import math

import numpy as np

from rimroll import solver
from rimroll.study import checks
from rimroll.study.registry import PHYSICAL_KEYS, SWEEP_KEYS, Axis, Study, UserError

META = {  # units and long_name of an outer axis
    "mu": ("1", "Coulomb friction coefficient"),
    "v_throw": ("m s-1", "throw speed whose kinetic energy bounds the steady motion (59)"),
    "j": ("1", "dimensionless moment of inertia of the ball, J = j m r^2"),
    "rho_over_R": ("1", "ratio rho/R of the ball centre's distance from the rim's middle circle to "
                        "the rim's major radius (R and a fixed, r = rho - a)"),
    "k_r": ("s-1", "rolling-resistance rate C_r/(j m R^2) of (83)"),
    "k_d": ("s-1", "drilling-resistance rate C_d/(j m R^2) of (83)"),
    "omega2": ("s-1", "initial orthogonal angular velocity"),
    "omega3": ("s-1", "initial circular angular velocity"),
    "sigma": ("1", "noise level: the spread of the arriving state in units of the study's sigma_* settings"),
}
assert set(META) == set(SWEEP_KEYS)


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
    for key in SWEEP_KEYS:
        if key not in order and isinstance(base.get(key), float):
            check_value(key, base[key])
    checks.check_settings(study.name, base, physical=(*PHYSICAL_KEYS, *SWEEP_KEYS))
    outer = _outer_axes(settings, order)
    params = params_from(base)
    grid = _regrid(grid_axes(study, base), grid_values)
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


def check_value(key: str, value) -> None:
    """Ranges of the non-physical sweep keys (the physical ones are checked by Params)."""
    if key == "v_throw" and not (math.isfinite(value) and value >= 0):
        raise UserError(f"parameter v_throw={value!r} is out of range: allowed 0 <= v_throw < inf [m/s]")
    if key == "sigma" and not (math.isfinite(value) and value >= 0):
        raise UserError(f"parameter sigma={value!r} is out of range: allowed 0 <= sigma < inf (a noise level)")
    if key in ("omega2", "omega3") and not math.isfinite(value):
        raise UserError(f"parameter {key}={value!r} is out of range: allowed a finite rate [1/s]")


# ------------------------------------------------------------------ --set items


def parse_set(item: str) -> tuple[str, str]:
    """Split ``KEY=VALUE``; :class:`UserError` when malformed."""
    key, sep, value = item.partition("=")
    key, value = key.strip(), value.strip()
    if not sep or not key or not value:
        raise UserError(f"malformed --set {item!r}; expected KEY=VALUE, e.g. --set mu=0.5")
    return key, value


def parse_values(key: str, text: str):
    """A tuple of floats for a list or range, else ``None`` (the text is a scalar).

    At most :data:`study.checks.MAX_AXIS` values."""
    if ":" in text:
        parts = text.split(":")
        if len(parts) != 3:
            raise UserError(f"--set {key}={text}: a range is start:stop:num, e.g. {key}=0.4:0.6:5")
        start, stop = _float(key, parts[0]), _float(key, parts[1])
        try:
            num = int(parts[2])
        except ValueError:
            raise UserError(f"--set {key}={text}: num of start:stop:num must be an integer") from None
        if num < 2:
            raise UserError(f"--set {key}={text}: a range needs num >= 2 points (give one value as a scalar)")
        if num > checks.MAX_AXIS:
            raise UserError(f"--set {key}={text}: at most {checks.MAX_AXIS} values per swept setting; got {num}")
        if not (math.isfinite(start) and math.isfinite(stop)) or start == stop:
            raise UserError(f"--set {key}={text}: a range needs finite start != stop")
        return tuple(float(v) for v in np.linspace(start, stop, num))
    if "," in text:
        items = [t.strip() for t in text.split(",")]
        if any(not t for t in items):
            raise UserError(f"--set {key}={text}: empty item in the list")
        if len(items) > checks.MAX_AXIS:
            raise UserError(f"--set {key}: at most {checks.MAX_AXIS} values per swept setting; got {len(items)}")
        return tuple(_float(key, t) for t in items)
    return None


def _float(key: str, text: str) -> float:
    try:
        return float(text)
    except ValueError:
        raise UserError(f"--set {key}={text}: expected a number") from None


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
            return int(text)
        if isinstance(default, float):
            return float(text)
        return type(default)(text)
    except ValueError:
        kind = {bool: "true/false", int: "an integer", float: "a number"}.get(type(default), type(default).__name__)
        raise UserError(f"--set {key}={text}: expected {kind}") from None


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
    for item in sets:
        key, text = parse_set(item)
        values = parse_values(key, text)
        if values is not None and key in grid_names:
            grid[key] = values
            continue
        if key in study.ignores:
            raise UserError(f"--set {key}={text}: study {study.name!r} does not use {key!r} "
                            f"({study.ignores[key]})")
        if key not in settings:
            raise UserError(f"unknown setting {key!r} for study {study.name!r}; "
                            f"known: {', '.join(sorted(k for k in settings if k not in study.ignores))}")
        if values is None:
            default = settings[key]
            default = 1.0 if key in SWEEP_KEYS or isinstance(default, (tuple, list)) else default
            settings[key] = _convert(key, text, default)
            if key in order:
                order.remove(key)
        elif key in study.sweepable:
            settings[key] = values
            if key not in order:
                order.append(key)
        else:
            sweepable = ", ".join(study.sweepable) or "none"
            raise UserError(f"--set {key}={text}: {key!r} cannot be swept in study {study.name!r} "
                            f"(sweepable: {sweepable}; or a grid axis: {', '.join(sorted(grid_names))})")
    settings = {k: (tuple(float(x) for x in v) if isinstance(v, (tuple, list)) else v) for k, v in settings.items()}
    return settings, order, grid


def _outer_axes(settings: dict, order: list[str]) -> list[Axis]:
    """The outer axes of the swept keys, each value validated with the other settings at base."""
    base = base_settings(settings)
    axes = []
    for key in order:
        values = settings[key]
        for v in values:
            check_value(key, v)
            if key in PHYSICAL_KEYS or key == "rho_over_R":
                params_from({**base, key: v})
        units, long_name = META[key]
        try:
            axes.append(Axis(key, np.array(values), units, long_name))
        except ValueError as exc:
            raise UserError(f"--set {key}: {exc}") from None
    return axes


def _regrid(axes: list[Axis], grid: dict) -> list[Axis]:
    """Grid axes with the values given by ``--set AXIS=list|range``."""
    out = []
    for a in axes:
        if a.name in grid:
            if a.aux:
                raise UserError(f"--set {a.name}: axis {a.name!r} carries auxiliary coordinates and "
                                "cannot be given new values")
            try:
                a = Axis(a.name, np.array(grid[a.name]), a.units, a.long_name)
            except ValueError as exc:
                raise UserError(f"--set {a.name}: {exc}") from None
        out.append(a)
    return out
