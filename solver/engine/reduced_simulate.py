"""``simulate``'s result for conservative rolling-only scenes by the reduction of Sect. 4.4.

:func:`solve` takes the states and parameters ``simulate`` takes and returns the same dict of
columns (``solver.engine.outputs``), by the rules of docs/outcome-engine.md, computed by
``solver.engine.reduced_rolling`` (root isolation and quadrature on the level of the conserved
quantities (60), (68), no time integration). :func:`unsupported` says, in one line, why a scene
cannot be solved so (None if it can).
"""

from __future__ import annotations

import os
from concurrent.futures import ThreadPoolExecutor

import numpy as np

from rimroll.solver._jit import vectorised
from rimroll.solver.engine import compiling, reduced_tables, rules
from rimroll.solver.engine import reduced_rolling as rr
from rimroll.solver.engine.outcomes import STEADY_MOTION, on_rim_reason
from rimroll.solver.engine.outputs import OUTPUTS
from rimroll.solver.physics import rolling
from rimroll.solver.physics.params import Params
from rimroll.solver.physics.steady_motion import stability

_normal_force = vectorised(rolling.normal_force)
_energy = vectorised(rolling.energy)
_CHUNKS_PER_WORKER = 8
COMPILE_NAME = "exact rolling solver (the reduction of Sect. 4.4)"
_GL_X, _GL_W = np.polynomial.legendre.leggauss(rr.GL_NODES)


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


def _wall_interval(beta):
    """Left end of the interval (-pi/2, 3 pi/2) + 2 pi n holding beta [rad]: F2 < 0 at beta = -pi/2 + 2 pi n
    on every level, so a motion from beta never leaves that interval."""
    return -0.5 * np.pi + 2.0 * np.pi * np.floor((beta + 0.5 * np.pi) / (2.0 * np.pi))


def _levels(x, table, p):
    """(C0 [1/s^2], P1, P2 [1/s]) of each state row (beta, omega1, omega2, omega3): P = Phi(beta0)^-1 z0
    from the table; C0 = omega1^2 + a sin(beta) + k omega2^2 + omega3^2 (exact at the start), or, for
    omega1 = 0 exactly, the value making the tabled omega1^2 vanish at beta0."""
    b = x[:, 0]
    ev = reduced_tables.evaluate
    f11, f12 = ev(table, b, reduced_tables.PHI11), ev(table, b, reduced_tables.PHI12)
    f21, f22 = ev(table, b, reduced_tables.PHI21), ev(table, b, reduced_tables.PHI22)
    det = f11 * f22 - f12 * f21
    p1 = (f22 * x[:, 2] - f12 * x[:, 3]) / det
    p2 = (-f21 * x[:, 2] + f11 * x[:, 3]) / det
    a = 2.0 * p.g * p.rho / ((1.0 + p.j) * p.r ** 2)
    c0 = x[:, 1] ** 2 + a * np.sin(b) + table.k * x[:, 2] ** 2 + x[:, 3] ** 2
    turn = x[:, 1] == 0.0
    if turn.any():
        q = (p1 ** 2 * ev(table, b, reduced_tables.Q11) + 2 * p1 * p2 * ev(table, b, reduced_tables.Q12)
             + p2 ** 2 * ev(table, b, reduced_tables.Q22))
        c0 = np.where(turn, a * np.sin(b) + q, c0)
    return np.ascontiguousarray(np.stack([c0, p1, p2], axis=-1))


def _constants(table, p: Params, t_max, rtol):
    c = np.empty(rr.N_C)
    c[rr.C_X] = table.x
    c[rr.C_K] = table.k
    c[rr.C_A] = 2.0 * p.g * p.rho / ((1.0 + p.j) * p.r ** 2)
    c[rr.C_R2RHO] = p.r ** 2 / p.rho
    c[rr.C_R2R] = p.r ** 2 / p.R
    c[rr.C_G] = p.g
    c[rr.C_TIME] = p.rho / p.r
    c[rr.C_ALPHA] = p.rho / p.R
    c[rr.C_BLO] = table.beta_lo
    c[rr.C_W] = table.width
    c[rr.C_NPAN] = table.values.shape[0]
    c[rr.C_RTOL] = rtol
    c[rr.C_TMAX] = t_max
    return c


def solve(states, params: Params, t_max=20.0, rtol=1e-8, workers=None) -> dict:
    """``simulate``'s result dict for the rolling states (..., 4) (beta [rad], omega1, omega2, omega3
    [1/s]) in the conservative rolling-only scene of ``params`` (ValueError naming the scene's
    non-conservative terms otherwise). rtol only sets what counts as a transversal omega1 zero
    (``rules.transversal_omega1_zero``); t_max [s] > 0. workers: threads (default: the cores).
    Arguments are checked by ``simulate``; called directly, they must already be valid."""
    why = unsupported(params)
    if why:
        raise ValueError(why)
    x = np.asarray(states, dtype=float)
    shape = x.shape[:-1]
    flat = np.ascontiguousarray(x.reshape(-1, 4))
    m = flat.shape[0]
    p = params.as_array()
    b, w1, w2, w3 = flat.T
    f2 = _normal_force(b, w1, w3, p)
    off = f2 < 0.0
    steady = ~off & vectorised(rules.on_steady_motion)(b, w1, w2, w3, p).astype(bool)
    run = ~(off | steady)

    t_end = np.zeros(m)
    f2_min = f2 / params.m
    half = np.full(m, np.nan)
    rev = np.zeros(m)
    end = flat.copy()
    outcome = np.full(m, STEADY_MOTION, dtype=np.int8)
    status = np.zeros(m, dtype=np.int8)
    evals = np.zeros(m, dtype=np.int64)
    for n in np.flatnonzero(off):
        outcome[n] = rules.fall_outcome(b[n], w1[n], w3[n], 0.0, 0.0, p)

    idx = np.flatnonzero(run)
    if idx.size:
        x0 = flat[idx]
        walls = _wall_interval(x0[:, 0])
        table = reduced_tables.build(params.rho / params.R, params.j, walls.min(), walls.max() + 2.0 * np.pi)
        levels = _levels(x0, table, params)
        c = _constants(table, params, float(t_max), float(rtol))
        res = np.empty((idx.size, rr.N_R))
        resi = np.zeros((idx.size, rr.N_RI), dtype=np.int64)
        _run_threads(x0, levels, table, c, p, res, resi, workers)
        t_end[idx] = res[:, rr.R_T]
        f2_min[idx] = res[:, rr.R_F2MIN]
        half[idx] = res[:, rr.R_HALF]
        rev[idx] = res[:, rr.R_REV]
        end[idx] = res[:, rr.R_BETA:rr.R_W3 + 1]
        outcome[idx] = resi[:, rr.RI_OUTCOME]
        status[idx] = resi[:, rr.RI_STATUS]
        evals[idx] = resi[:, rr.RI_EVALS]

    e0 = _energy(b, w1, w2, w3, p)
    e1 = _energy(end[:, 0], end[:, 1], end[:, 2], end[:, 3], p)
    out = {
        "t_end": t_end, "f2_min": f2_min * params.m, "half_period": half, "revolutions": rev,
        "slip_time": np.zeros(m),
        "energy_drift": np.abs(e1 - e0) / np.maximum(np.abs(e0), params.m * params.g * params.rho),
        "beta_end": end[:, 0], "omega1_end": end[:, 1], "omega2_end": end[:, 2], "omega3_end": end[:, 3],
        "outcome": outcome, "slip_phases": np.zeros(m), "n_steps": evals, "status": status,
        "n_searched": np.zeros(m), "n_slip_steps": np.zeros(m),
        "u1_end": np.zeros(m), "u3_end": np.zeros(m),  # rolling only: the contact point never slips [m/s]
    }
    h = np.full(m, np.nan)
    if steady.any():
        h[steady] = stability(flat[steady, 0], flat[steady, 3], params)
    out["steady_h"] = h
    result = {}
    for item in OUTPUTS:
        if item.name != "on_rim_reason":
            result[item.name] = np.asarray(out[item.name]).astype(item.dtype).reshape(shape)
    result["on_rim_reason"] = on_rim_reason(result["outcome"], result["status"], result["slip_phases"])
    return result


def _run_threads(x0, levels, table, c, p, res, resi, workers):
    """``reduced_rolling.solve_many`` over interleaved chunks of the states on ``workers`` threads."""
    workers = min(os.cpu_count() or 1, 1024) if workers is None else int(workers)
    m = x0.shape[0]
    n_chunks = min(m, workers * _CHUNKS_PER_WORKER) if workers > 1 else 1
    args = (table.curvature, c, p, _GL_X, _GL_W)
    typed_like = np.empty((0, rr.N_ROWS, rr.N_COEF))  # a working table's type, without copying one
    compiling.compile_here_announced(rr.solve_many, (x0, levels, typed_like, *args, res, resi), COMPILE_NAME)
    if n_chunks <= 1:
        rr.solve_many(x0, levels, rr.working_table(table), *args, res, resi)
        return
    order = np.argsort(np.arange(m) % n_chunks, kind="stable")
    bounds = np.searchsorted(order % n_chunks, np.arange(n_chunks + 1))
    xs, ls = x0[order], levels[order]
    rs, ris = np.empty_like(res), np.empty_like(resi)

    def run(lo, hi):
        rr.solve_many(xs[lo:hi], ls[lo:hi], rr.working_table(table), *args, rs[lo:hi], ris[lo:hi])

    with ThreadPoolExecutor(max_workers=workers) as pool:
        for fut in [pool.submit(run, lo, hi) for lo, hi in zip(bounds[:-1], bounds[1:])]:
            fut.result()
    res[order] = rs
    resi[order] = ris
