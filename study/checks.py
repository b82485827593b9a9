"""Checks of a run's settings and sizes made before any work starts (one line each, exit 2).

``study.settings.resolve`` calls :func:`check_settings` on every setting of the run, every value
of a swept setting included, and :func:`check_values` on the new values ``--set`` gives a grid
axis, so that a value the computation would refuse inside a dask task (``rtol=0``,
``t_max=-1``, ``method=rk4``, ``seed=-1``, ...) is refused up front. What each setting allows is
declared once, in the setting table (:mod:`rimroll.study.setting_table`; the physical parameters'
ranges in ``rimroll.solver.physics.params``): a setting no table entry names is checked by its
wildcard rule (``t_max*``, ``n_*``) or, if it is a number, as finite and of magnitude at most
:data:`MAX_MAGNITUDE`.

Sizes: a swept list or range holds at most :data:`MAX_AXIS` values and a cube at most
:data:`MAX_CHUNKS` chunks (each chunk is a part file) and :data:`MAX_POINTS` points.
"""

from __future__ import annotations

import numpy as np

from rimroll.solver._arguments import MAX_WORKERS  # the CPU backend's cap (solver.simulate) is the --workers cap
from rimroll.solver.physics.params import DISSIPATION_KEYS
from rimroll.study.registry import UserError
from rimroll.study.setting_table import MAX_AXIS, MAX_MAGNITUDE, ORDERED, lookup, ordered_pairs

__all__ = ["MAX_AXIS", "MAX_CHUNKS", "MAX_MAGNITUDE", "MAX_POINTS", "MAX_WORKERS", "check_setting",
           "check_order", "check_settings", "check_size", "check_values", "check_workers", "require_conservative"]

DEFAULT_TIMEOUT = 30.0  # [s] bound on waiting for a scheduler and for its workers (study.fanout)
MAX_CHUNKS = 200_000  # chunks of one cube (one part file each)
MAX_POINTS = 10**10  # grid points of one cube


def check_setting(study: str, key: str, value, what: str = "setting") -> None:
    """One value of setting ``key`` of study ``study``; a :class:`UserError` naming the setting, the
    value and what the setting allows when it allows no such value (``what``: the word for ``key``
    in the message). A physical parameter's message is the one ``solver.Params`` gives."""
    setting = lookup(key)
    problem = setting.problem(value)
    if problem is None:
        return
    if setting.physical:
        raise UserError(f"parameter {key}={value!r} is out of range: {problem}")
    verb = "is not allowed" if setting.choices is not None else "is out of range"
    raise UserError(f"{what} {key}={value!r} {verb} for study {study!r}: {problem}")


def check_values(study: str, key: str, values, what: str = "setting") -> None:
    """Every value of a list or range of ``key`` (a swept setting, new values of a grid axis)."""
    for value in values:
        check_setting(study, key, value, what)


def check_settings(study: str, settings: dict) -> None:
    """Every setting of a run: a scalar, or each value of a swept one (a tuple); None is unset."""
    for key, value in settings.items():
        if isinstance(value, tuple):
            check_values(study, key, value)
        elif value is not None:
            check_setting(study, key, value)
    check_order(study, settings)


def check_order(study: str, settings: dict) -> None:
    """Every ``*_min``/``*_max`` pair of the setting table (:data:`ORDERED`: ``beta_min < beta_max``,
    ``beta0_min <= beta0_max``, ...) and of the study's own settings, one rule
    (``setting_table.ordered_pairs``): a UserError naming both values."""
    for low, high, strict in sorted({*ORDERED, *ordered_pairs(settings)}):
        a, b = settings.get(low), settings.get(high)
        if not all(isinstance(v, (int, float)) and not isinstance(v, bool) for v in (a, b)):
            continue
        if a > b or (strict and a == b):
            sign = "<" if strict else "<="
            raise UserError(f"settings {low}={a!r} and {high}={b!r} of study {study!r} are out of order: "
                            f"{low} {sign} {high} is required")


def check_size(study: str, n_chunks: int, n_points: int) -> None:
    """Refuse cubes beyond :data:`MAX_CHUNKS` chunks or :data:`MAX_POINTS` points."""
    if n_chunks > MAX_CHUNKS or n_points > MAX_POINTS:
        raise UserError(f"study {study!r}: the cube has {n_chunks} chunks and {n_points:.3g} points; "
                        f"at most {MAX_CHUNKS} chunks and {MAX_POINTS:.0e} points per run: sweep fewer "
                        "values, or split the sweep into several runs with different --out")


def check_workers(workers, name: str = "--workers") -> None:
    """A number of local threads: None (one per core) or an integer from 1 to MAX_WORKERS; ``name``: the
    option or keyword the user gave it as."""
    if workers is None:
        return
    if isinstance(workers, (bool, np.bool_)) or not isinstance(workers, (int, np.integer)):
        raise UserError(f"{name} must be an integer between 1 and {MAX_WORKERS}; got {workers!r}")
    if not (1 <= workers <= MAX_WORKERS):
        raise UserError(f"{name} must be between 1 and {MAX_WORKERS}; got {workers}")


def require_conservative(s: dict, why: str) -> None:
    """ValueError (one line) unless every dissipation setting (``DISSIPATION_KEYS``) of the settings ``s``
    is 0; ``why`` opens the line: what needs the conservative rolling equations."""
    on = {k: s[k] for k in DISSIPATION_KEYS if s[k] != 0}
    if on:
        raise ValueError(f"{why}: need " + " = ".join(DISSIPATION_KEYS) + " = 0; got "
                         + ", ".join(f"{k}={v}" for k, v in on.items()))
