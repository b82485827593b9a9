"""Checks of a run's settings and sizes made before any work starts (one line each, exit 2).

``study.plan.make_plan`` calls :func:`check_settings` on the scalar settings of every point of
the cube, so that a value the computation would refuse inside a dask task (``rtol=0``,
``t_max=-1``, ``method=rk4``, ``seed=-1``, ...) is refused up front. The rules are by setting
name and shared by every study that has the setting:

- ``rtol``: 1e-14 <= rtol <= 1e-2 (what ``solver.simulate`` accepts); ``atol``: finite, > 0;
- ``t_max*``: finite, > 0 [s]; ``method``: a method of ``solver.simulate`` (dp5, dop853);
- ``mu_slip``: a friction coefficient >= 0 (inf allowed); ``k_dissipation``: finite, >= 0 [1/s];
- ``backend``: a backend of ``solver.simulate`` (cpu, cuda, auto);
- ``seed``: an integer >= 0; ``n_*`` (grid sizes, counts): 1 .. :data:`MAX_AXIS` (0 allowed for
  the counts of :data:`ZERO_COUNTS`);
- every other number: finite, and of magnitude below :data:`MAX_MAGNITUDE` (an axis spanning
  +-1e308 overflows).

Sizes: a swept list or range holds at most :data:`MAX_AXIS` values and a cube at most
:data:`MAX_CHUNKS` chunks (each chunk is a part file) and :data:`MAX_POINTS` points.
"""

from __future__ import annotations

import math

from rimroll.study.registry import UserError

MAX_AXIS = 100_000  # values of one swept list/range, and of an n_* grid size
MAX_CHUNKS = 200_000  # chunks of one cube (one part file each)
MAX_POINTS = 10**10  # grid points of one cube
MAX_MAGNITUDE = 1e12  # |value| of a numeric setting (coordinates, bounds): far beyond any physical use
MAX_WORKERS = 1024  # --workers: threads of the local cluster
ZERO_COUNTS = ("n_fine", "n_coarse", "n_sample")  # counts that may be 0 (predictability: no eps below /
# above one grid step, no simulated sample)


def _methods() -> list[str]:
    from rimroll.solver.engine.simulate import TABLEAUS

    return sorted(TABLEAUS)


def _number(key, value) -> bool:
    return isinstance(value, (int, float)) and not isinstance(value, bool)


def check_setting(study: str, key: str, value) -> None:
    """One setting of study ``study``; :class:`UserError` naming the rule when it is broken."""
    where = f"setting {key}={value!r} of study {study!r}"
    if key == "backend":
        from rimroll.solver.engine.backends import BACKENDS

        if value not in BACKENDS:
            raise UserError(f"{where}: allowed backends are {', '.join(BACKENDS)}")
        return
    if key == "method" and isinstance(value, str):
        methods = _methods()
        if value not in methods:
            raise UserError(f"{where}: allowed methods are {', '.join(methods)}")
        return
    if not _number(key, value):
        return
    v = float(value)
    if key == "rtol":
        if not (1e-14 <= v <= 1e-2):
            raise UserError(f"{where} is out of range: allowed 1e-14 <= rtol <= 1e-2")
    elif key == "atol":
        if not (math.isfinite(v) and v > 0):
            raise UserError(f"{where} is out of range: allowed a finite atol > 0")
    elif key.startswith("t_max"):
        if not (math.isfinite(v) and 0 < v <= MAX_MAGNITUDE):
            raise UserError(f"{where} is out of range: allowed 0 < {key} <= {MAX_MAGNITUDE:g} [s]")
    elif key == "mu_slip":
        if not (v >= 0):
            raise UserError(f"{where} is out of range: allowed 0 <= mu_slip <= inf")
        return
    elif key == "k_dissipation":
        if not (math.isfinite(v) and 0 <= v <= MAX_MAGNITUDE):
            raise UserError(f"{where} is out of range: allowed a finite k_dissipation >= 0 [1/s]")
    elif key == "seed":
        if not (isinstance(value, int) and value >= 0):
            raise UserError(f"{where} is out of range: allowed an integer seed >= 0")
    elif key.startswith("n_") and isinstance(value, int):
        low = 0 if key in ZERO_COUNTS else 1
        if not (low <= value <= MAX_AXIS):
            raise UserError(f"{where} is out of range: allowed {low} <= {key} <= {MAX_AXIS}")
    if not math.isfinite(v) or abs(v) > MAX_MAGNITUDE:
        raise UserError(f"{where} is out of range: allowed a finite value of magnitude <= {MAX_MAGNITUDE:g}")


def check_settings(study: str, settings: dict, physical=()) -> None:
    """Every non-physical scalar setting of one point of the cube (physical ones: ``solver.Params``)."""
    for key, value in settings.items():
        if key in physical or isinstance(value, tuple) or value is None:
            continue
        check_setting(study, key, value)


def check_size(study: str, n_chunks: int, n_points: int) -> None:
    """Refuse cubes beyond :data:`MAX_CHUNKS` chunks or :data:`MAX_POINTS` points."""
    if n_chunks > MAX_CHUNKS or n_points > MAX_POINTS:
        raise UserError(f"study {study!r}: the cube has {n_chunks} chunks and {n_points:.3g} points; "
                        f"at most {MAX_CHUNKS} chunks and {MAX_POINTS:.0e} points per run: sweep fewer "
                        "values, or split the sweep into several runs with different --out")


def check_workers(workers) -> None:
    if workers is not None and not (1 <= workers <= MAX_WORKERS):
        raise UserError(f"--workers must be between 1 and {MAX_WORKERS}; got {workers}")
