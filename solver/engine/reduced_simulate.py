"""``simulate``'s result for conservative rolling-only scenes by the reduction of Sect. 4.4.

:func:`solve` takes the states and parameters ``simulate`` takes and returns the same dict of
columns (``solver.engine.outputs``), by the rules of docs/outcome-engine.md, computed by
``solver.engine.reduced_rolling`` (root isolation and quadrature on the level of the conserved
quantities (60), (68), no time integration). :func:`unsupported` says, in one line, why a scene
cannot be solved so (None if it can).
"""

from __future__ import annotations

import functools
import os
from concurrent.futures import ThreadPoolExecutor

import numpy as np

from rimroll.solver._jit import python_version
from rimroll.solver.engine import reduced_compiled, reduced_legs, reduced_tables, rules
from rimroll.solver.engine.outcomes import STEADY_MOTION, on_rim_reason
from rimroll.solver.engine.outputs import OUTPUTS
from rimroll.solver.physics import rolling
from rimroll.solver.physics.params import Params
from rimroll.solver.physics.steady_motion import stability

SPLIT_MIN = 4096
"""Fewest states ``solve`` splits among its threads from start to end (below: only the legs run in threads)."""
_normal_force = python_version(rolling.normal_force)
_energy = python_version(rolling.energy)
_on_steady_motion = python_version(rules.on_steady_motion)
_omega_scale = python_version(rules.omega_scale)


def _steady(b, w1, w2, w3, p):
    """``rules.on_steady_motion`` of the states (arrays), evaluated only where it can hold: its residual is at least
    |omega1| / omega_scale, so a state with |omega1| over twice STEADY_TOL omega_scale (a margin far above the
    rounding of either side) is not steady: the same answer, less work."""
    maybe = np.abs(w1) <= 2.0 * rules.STEADY_TOL * _omega_scale(w1, w2, w3, p)
    steady = np.zeros(b.shape, dtype=bool)
    if maybe.any():
        steady[maybe] = np.asarray(_on_steady_motion(b[maybe], w1[maybe], w2[maybe], w3[maybe], p), dtype=bool)
    return steady


def unsupported(params: Params, terms=()) -> str | None:
    """Why the reduced solver cannot run this scene (one line), or None: it needs rolling only
    (mu = inf), no dissipation (k_r = k_d = c_r = c_d = 0), no air (rho_air = 0) and no load term."""
    if terms:
        return f"the reduced solver runs the conservative rolling-only scene; got load terms {terms!r}"
    bad = [f"{name}={getattr(params, name)!r}" for name in ("k_r", "k_d", "c_r", "c_d", "rho_air")
           if getattr(params, name) != 0]
    if np.isfinite(params.mu):
        bad.insert(0, f"mu={params.mu!r}")
    if bad:
        return ("the reduced solver runs the conservative rolling-only scene (mu = inf, k_r = k_d = c_r = c_d = "
                f"rho_air = 0); got {', '.join(bad)}")
    return None


def _whole_turns(beta):
    """2 pi n [rad] with beta - 2 pi n in [-pi/2, 3 pi/2): the equations hold beta only in sin and cos, and F2 < 0
    at beta = -pi/2 on every level, so a motion from beta - 2 pi n never leaves that interval: the states are
    solved there (on one table) and their end angles shifted back."""
    return 2.0 * np.pi * np.floor((beta + 0.5 * np.pi) / (2.0 * np.pi))


@functools.lru_cache(maxsize=8)
def _table(rho_over_R, j):
    """The table of (62) on [-pi/2, 3 pi/2] for rho/R and j (kept for the next calls with the same ones)."""
    return reduced_tables.build(rho_over_R, j, -0.5 * np.pi, 1.5 * np.pi)


def _levels(x, table, p, turn):
    """(C0 [1/s^2], P1, P2 [1/s]) of the state rows (beta, omega1, omega2, omega3): P = Phi(beta0)^-1 z0
    from the table; C0 = omega1^2 + a sin(beta) + k omega2^2 + omega3^2 (exact at the start), or, for the
    states that start on a turning point (``turn``), the value making the tabled omega1^2 vanish at beta0."""
    b = x[:, 0]
    t = reduced_tables
    f11, f12, f21, f22 = reduced_compiled.evaluate_many(table, b, (t.PHI11, t.PHI12, t.PHI21, t.PHI22))
    det = f11 * f22 - f12 * f21
    p1 = (f22 * x[:, 2] - f12 * x[:, 3]) / det
    p2 = (-f21 * x[:, 2] + f11 * x[:, 3]) / det
    a = 2.0 * p.g * p.rho / ((1.0 + p.j) * p.r ** 2)
    c0 = x[:, 1] ** 2 + a * np.sin(b) + table.k * x[:, 2] ** 2 + x[:, 3] ** 2
    if turn.any():
        c0 = np.where(turn, c0 - reduced_legs.omega1_squared(table, a, b, c0, p1, p2), c0)  # W(beta0) = 0 in the table
    return c0, p1, p2


def solve(states, params: Params, t_max=20.0, rtol=1e-8, workers=None) -> dict:
    """``simulate``'s result dict for the rolling states (..., 4) (beta [rad], omega1, omega2, omega3
    [1/s]) in the conservative rolling-only scene of ``params`` (ValueError naming the scene's
    non-conservative terms otherwise). rtol only sets what counts as a transversal omega1 zero
    (``rules.transversal_omega1_zero``); t_max [s] > 0. workers: threads (default: the cores).
    Arguments are checked by ``simulate``; called directly, they must already be valid.

    With several workers and at least ``SPLIT_MIN`` states, each thread solves every workers-th state from start
    to end (numpy releases the GIL in its array operations, the legs run in the compiled library), so the
    numpy side runs in parallel too; every state's answer is the same as on one thread."""
    why = unsupported(params)
    if why:
        raise ValueError(why)
    x = np.asarray(states, dtype=float)
    shape = x.shape[:-1]
    flat = np.ascontiguousarray(x.reshape(-1, 4))
    m = flat.shape[0]
    workers = min(os.cpu_count() or 1, 1024) if workers is None else int(workers)
    _table(params.rho / params.R, params.j)  # built once, before the threads share it
    if workers > 1 and m >= SPLIT_MIN:
        parts = [np.arange(k, m, workers) for k in range(workers)]
        with ThreadPoolExecutor(max_workers=workers) as pool:
            got = list(pool.map(lambda rows: _solve_flat(flat[rows], params, t_max, rtol, 1), parts))
        result = {name: np.empty((m,) + col.shape[1:], dtype=col.dtype) for name, col in got[0].items()}
        for rows, part in zip(parts, got):
            for name, col in part.items():
                result[name][rows] = col
    else:
        result = _solve_flat(flat, params, t_max, rtol, workers)
    return {name: col.reshape(shape + col.shape[1:]) for name, col in result.items()}


def _solve_flat(flat, params, t_max, rtol, workers) -> dict:
    """``solve`` for the state rows flat (m, 4): the result columns (m,), legs on ``workers`` threads."""
    m = flat.shape[0]
    p = params.as_array()
    b, w1, w2, w3 = flat.T
    f2 = _normal_force(b, w1, w3, p)
    off = f2 < 0.0
    steady = ~off & _steady(b, w1, w2, w3, p)
    run = ~(off | steady)

    out = {"t_end": np.zeros(m), "f2_min": f2 / params.m, "half_period": np.full(m, np.nan), "revolutions": np.zeros(m),
           "end": flat.copy(), "outcome": np.full(m, STEADY_MOTION, dtype=np.int8),
           "status": np.zeros(m, dtype=np.int8), "n_steps": np.zeros(m, dtype=np.int64)}
    out["outcome"][off] = reduced_legs.fall_outcomes(b[off], w1[off], w3[off], p)
    idx = np.flatnonzero(run)
    if idx.size:
        x0 = flat[idx]
        turns = _whole_turns(x0[:, 0])
        x0[:, 0] -= turns
        table = _table(params.rho / params.R, params.j)
        turn0 = reduced_legs.turning_starts(x0, params, table.width)
        level = reduced_legs.Level(table, params, *_levels(x0, table, params, turn0))
        got = reduced_legs.motions(x0, level, float(t_max), float(rtol), turn0, workers)
        got["end"][:, 0] += turns
        for name, column in got.items():
            out[name][idx] = column
    return _columns(out, flat, (m,), params)


def _columns(out, flat, shape, params):
    """The result dict of ``simulate`` (``solver.engine.outputs``) from the solved columns."""
    p = params.as_array()
    m = flat.shape[0]
    end = out.pop("end")
    b, w1, w2, w3 = flat.T
    e0 = _energy(b, w1, w2, w3, p)
    e1 = _energy(end[:, 0], end[:, 1], end[:, 2], end[:, 3], p)
    steady = out["outcome"] == STEADY_MOTION
    h = np.full(m, np.nan)
    if steady.any():
        h[steady] = stability(flat[steady, 0], flat[steady, 3], params)
    cols = {
        **out, "f2_min": out["f2_min"] * params.m, "revolutions": out["revolutions"], "slip_time": np.zeros(m),
        "energy_drift": np.abs(e1 - e0) / np.maximum(np.abs(e0), params.m * params.g * params.rho),
        "beta_end": end[:, 0], "omega1_end": end[:, 1], "omega2_end": end[:, 2], "omega3_end": end[:, 3],
        "slip_phases": np.zeros(m), "n_searched": np.zeros(m), "n_slip_steps": np.zeros(m),
        "u1_end": np.zeros(m), "u3_end": np.zeros(m),  # rolling only: the contact point never slips [m/s]
        "steady_h": h,
    }
    result = {}
    for item in OUTPUTS:
        if item.name != "on_rim_reason":
            result[item.name] = np.asarray(cols[item.name]).astype(item.dtype, copy=False).reshape(shape)
    result["on_rim_reason"] = on_rim_reason(result["outcome"], result["status"], result["slip_phases"])
    return result
