"""Conservative rolling motions put together from their legs (the reduction of Sect. 4.4).

A motion on its level is a sequence of legs between events (``solver.engine.reduced_rolling``): from
the start beta0 in the direction of omega1 to the first event b1, and, when b1 is a turning point,
from beta0 the other way to b2. Everything after is known: the ball swings between b1 and b2 with
half period T = t1 + t2 (or falls at b2), so the outcome follows by the rules of
docs/outcome-engine.md, for whole arrays of states at once:

* a fall on the first leg (F2 = 0 at b1): fall in or out (the parabola of ``flight.landing_distance``,
  :func:`fall_outcomes`) at t1;
* a turning point at b1 and a fall at b2: the fall at t1 + T;
* turning points at both ends: ``periodic_rolling`` at the second *transversal* omega1 zero
  (``rules.transversal_omega1_zero`` at the simulation's rtol; a start with omega1 = 0 is the
  first when transversal, and so is a start the tables cannot tell from a turning point:
  :func:`turning_starts`), half_period the time between the two;
* any of these after t_max: ``on_rim_at_t_max``, the state there found by Newton on the time of
  the leg it falls in (``_at_time``); an oscillation whose turning points never count is followed
  in closed form (k half swings of T), so no cap on the number of swings applies.
"""

from __future__ import annotations

import os
from concurrent.futures import ThreadPoolExecutor
from typing import NamedTuple

import numpy as np

from rimroll.solver._jit import python_version
from rimroll.solver.engine import compiling, reduced_compiled, reduced_tables, rules
from rimroll.solver.engine import reduced_rolling as rr
from rimroll.solver.engine.outcomes import FALL_IN, FALL_OUT, MAX_STEPS, NON_FINITE, ON_RIM_AT_T_MAX, PERIODIC_ROLLING
from rimroll.solver.physics import kinematics, rolling
from rimroll.solver.physics.params import P_G, P_R_RIM, Params

COMPILE_NAME = "exact rolling solver (the reduction of Sect. 4.4)"
_CHUNKS_PER_WORKER = 8
def _rule() -> np.ndarray:
    """The quadrature rule's rows of ``reduced_rolling`` (R_NODES .. NRULE)."""
    x, wk, wg = reduced_tables.kronrod()
    quarter, half = 0.25 * np.pi * (x + 1.0), 0.5 * np.pi * (x + 1.0)
    return np.ascontiguousarray(np.stack([x, wk, wg, np.sin(quarter), np.sin(0.5 * quarter), np.sin(half),
                                          np.sin(0.5 * half), np.cos(0.5 * half)]))


RULE = _rule()
_transversal = python_version(rules.transversal_omega1_zero)
_rates = python_version(rolling.rolling_rhs)
_centre_position = python_version(kinematics.centre_position)
_centre_velocity = python_version(kinematics.centre_velocity)


def fall_outcomes(beta, omega1, omega3, p) -> np.ndarray:
    """FALL_IN or FALL_OUT of rolling separation states (arrays) in a scene without air: the parabola of
    ``flight.landing_distance`` in numpy (``rules.fall_outcome`` for one state, compiled)."""
    d, z = _centre_position(beta, p)
    v_rad, v_z, v_tan = _centre_velocity(beta, omega1, omega3, 0.0, 0.0, p)
    g = p[P_G]
    root = np.sqrt(v_z * v_z + 2.0 * g * np.maximum(z, 0.0))
    with np.errstate(divide="ignore", invalid="ignore"):
        tf = np.where(z <= 0.0, 0.0, np.where(v_z >= 0.0, (v_z + root) / g, 2.0 * z / (root - v_z)))
    x, y = d + v_rad * tf, v_tan * tf
    return np.where(np.sqrt(x * x + y * y) < p[P_R_RIM], FALL_IN, FALL_OUT).astype(np.int8)


class Level(NamedTuple):
    """The table of a parameter set and the levels of an array of states: C0 [1/s^2], P1, P2 [1/s]."""

    table: reduced_tables.Table
    params: Params
    c0: np.ndarray
    p1: np.ndarray
    p2: np.ndarray

    @property
    def a(self) -> float:
        """2 g rho / ((1 + j) r^2) [1/s^2]: the potential's coefficient in omega1^2."""
        p = self.params
        return 2.0 * p.g * p.rho / ((1.0 + p.j) * p.r ** 2)

    def constants(self) -> np.ndarray:
        """The constants vector of ``reduced_rolling`` (N_C)."""
        p, t = self.params, self.table
        c = np.empty(rr.N_C)
        c[rr.C_A] = self.a
        c[rr.C_R2RHO] = p.r ** 2 / p.rho
        c[rr.C_R2R] = p.r ** 2 / p.R
        c[rr.C_G] = p.g
        c[rr.C_TIME] = p.rho / p.r
        c[rr.C_ALPHA] = p.rho / p.R
        c[rr.C_BLO] = t.beta_lo
        c[rr.C_W] = t.width
        c[rr.C_NPAN] = t.values.shape[0]
        return c

    def spins(self, rows, beta):
        """(omega2, omega3) [1/s] = Phi(beta) P of the states ``rows`` at beta [rad]."""
        t = reduced_tables
        f11, f12, f21, f22 = reduced_compiled.evaluate_many(self.table, beta, (t.PHI11, t.PHI12, t.PHI21, t.PHI22))
        p1, p2 = self.p1[rows], self.p2[rows]
        return f11 * p1 + f12 * p2, f21 * p1 + f22 * p2

    def end_state(self, rows, beta):
        """(omega1^2 [1/s^2], omega2, omega3 [1/s]) of the states ``rows`` at beta [rad], from one table evaluation."""
        t = reduced_tables
        f11, f12, f21, f22, sin, q11, q12, q22 = reduced_compiled.evaluate_many(
            self.table, beta, (t.PHI11, t.PHI12, t.PHI21, t.PHI22, t.SIN, t.Q11, t.Q12, t.Q22))
        c0, p1, p2 = self.c0[rows], self.p1[rows], self.p2[rows]
        w = _level_w(self.a, c0, p1, p2, sin, q11, q12, q22)
        return w, f11 * p1 + f12 * p2, f21 * p1 + f22 * p2

    def w(self, rows, beta):
        """omega1^2 [1/s^2] of the states ``rows`` at beta [rad]."""
        return omega1_squared(self.table, self.a, beta, self.c0[rows], self.p1[rows], self.p2[rows])


def omega1_squared(table, a, beta, c0, p1, p2):
    """omega1^2 [1/s^2] = C0 - a sin beta - P^T Q(beta) P on the level (C0, P1, P2) at beta [rad] (numpy)."""
    t = reduced_tables
    sin, q11, q12, q22 = reduced_compiled.evaluate_many(table, beta, (t.SIN, t.Q11, t.Q12, t.Q22))
    return _level_w(a, c0, p1, p2, sin, q11, q12, q22)


def _level_w(a, c0, p1, p2, sin, q11, q12, q22):
    """omega1^2 [1/s^2] on the level (C0, P1, P2) from the tabled sin beta and Q at the points."""
    return c0 - a * sin - (p1 * p1 * q11 + 2.0 * p1 * p2 * q12 + p2 * p2 * q22)


def run_legs(level: Level, rows, beta, d, sing, stop, workers) -> np.ndarray:
    """The legs (``reduced_rolling``'s algorithm) of the states ``rows`` from beta [rad] in direction d (+-1), W = 0
    at the start where sing, up to the first event or stop [rad]: (n, N_O) rows."""
    n = len(rows)
    jobs = np.empty((n, rr.N_J))
    jobs[:, rr.J_BETA] = beta
    jobs[:, rr.J_DIR] = d
    jobs[:, rr.J_SING] = sing
    jobs[:, rr.J_STOP] = stop
    p1, p2 = level.p1[rows], level.p2[rows]
    jobs[:, rr.J_C0] = level.c0[rows]
    jobs[:, rr.J_Q0] = p1 * p1
    jobs[:, rr.J_Q1] = 2.0 * p1 * p2
    jobs[:, rr.J_Q2] = p2 * p2
    jobs[:, rr.J_P1] = p1
    jobs[:, rr.J_P2] = p2
    out = np.zeros((n, rr.N_O))
    if n:
        _threads(jobs, level, out, workers)
    return out


def _scratch():
    return np.zeros((rr.N_WORK, reduced_tables.N_COEF)), np.zeros((rr.MAX_STACK, 2))


def _numba_legs(jobs, tab, nod, spread, c, rule, out):
    """``reduced_rolling.legs`` with scratch arrays of its own (the compiled library's call)."""
    rr.legs(jobs, tab, nod, spread, c, rule, *_scratch(), out)


def _threads(jobs, level, out, workers):
    """The legs (``reduced_compiled.legs``, else ``reduced_rolling.legs``) over interleaved chunks of the jobs on
    ``workers`` threads."""
    t = level.table
    args = (t.values, t.nodes, t.spread, level.constants(), RULE)
    legs = reduced_compiled.legs()  # compiled at install; without it, the numba kernel (compiled here, announced)
    if legs is None:
        compiling.compile_here_announced(rr.legs, (jobs[:0], *args, *_scratch(), out[:0]), COMPILE_NAME)
        legs = _numba_legs
    workers = min(os.cpu_count() or 1, 1024) if workers is None else int(workers)
    m = jobs.shape[0]
    n_chunks = min(m, workers * _CHUNKS_PER_WORKER) if workers > 1 and m > 64 else 1
    if n_chunks <= 1:
        legs(jobs, *args, out)
        return
    order = np.argsort(np.arange(m) % n_chunks, kind="stable")
    bounds = np.searchsorted(order % n_chunks, np.arange(n_chunks + 1))
    dealt = np.ascontiguousarray(jobs[order])
    got = np.empty_like(out)

    def run(lo, hi):
        legs(dealt[lo:hi], *args, got[lo:hi])

    with ThreadPoolExecutor(max_workers=workers) as pool:
        for fut in [pool.submit(run, lo, hi) for lo, hi in zip(bounds[:-1], bounds[1:])]:
            fut.result()
    out[order] = got


class _Result:
    """The columns being filled for n states (see :func:`motions`)."""

    def __init__(self, x0, t_max):
        n = x0.shape[0]
        self.x0, self.t_max = x0, t_max
        self.t = np.zeros(n)
        self.alpha = np.zeros(n)
        self.half = np.full(n, np.nan)
        self.fmin = np.full(n, np.inf)
        self.outcome = np.full(n, ON_RIM_AT_T_MAX, dtype=np.int8)
        self.status = np.zeros(n, dtype=np.int8)
        self.evals = np.zeros(n, dtype=np.int64)
        self.beta = x0[:, 0].copy()
        self.sign = np.zeros(n)  # the sign of omega1 at the end (0: a turning point)
        self.fell = np.zeros(n, dtype=bool)
        self.failed = np.zeros(n, dtype=bool)  # ends at its start

    def end(self, rows, beta, sign, t, alpha, fmin):
        self.beta[rows], self.sign[rows], self.t[rows], self.alpha[rows] = beta, sign, t, alpha
        self.fmin[rows] = fmin

    def fail(self, rows, kinds):
        self.failed[rows] = True
        self.status[rows] = np.where(kinds == rr.EV_FAIL, NON_FINITE, MAX_STEPS)
        self.outcome[rows] = ON_RIM_AT_T_MAX

    def count(self, rows, legs):
        self.evals[rows] += legs[:, rr.O_EVALS].astype(np.int64)
        self.status[rows] = np.where(legs[:, rr.O_OK] > 0.0, self.status[rows], MAX_STEPS)


def turning_starts(x0, params: Params, width: float) -> np.ndarray:
    """Which rolling states (n, 4) start on a turning point as far as the tables can tell: omega1 = 0, or omega1^2
    below the tables' rounding of omega1^2 (32 eps times its terms, a + k omega2^2 + omega3^2 + omega1^2) or below
    what the distance to the turning point can resolve (|dW/dbeta| 4e-16 (|beta0| + width); W = omega1^2,
    dW/dbeta = 2 omega1_dot rho/r; width [rad]: the table's panel). Such a ball turns within a rounding of
    beta0, after |omega1 / omega1_dot| (``motions`` adds that time)."""
    b0, w10, w20, w30 = x0.T
    slope = 2.0 * np.abs(_rates(b0, w10, w20, w30, params.as_array())[1]) * params.rho / params.r
    k = params.j / (1.0 + params.j)
    terms = 2.0 * params.g * params.rho / ((1.0 + params.j) * params.r ** 2) + k * w20 * w20 + w30 * w30 + w10 * w10
    return (w10 == 0.0) | (w10 * w10 <= np.maximum(slope * 4e-16 * (np.abs(b0) + width), 32 * 2.2e-16 * terms))


def motions(x0, level: Level, t_max: float, rtol: float, turn0, workers=None) -> dict:
    """The outcome of each rolling state of x0 (n, 4) that neither starts off the rim nor on a steady motion, on
    its level (turn0: the states that start on a turning point, ``turning_starts``): a dict of columns (t_end [s],
    f2_min [m/s^2] (F2/m), half_period [s], revolutions, end (n, 4), outcome, status, n_steps (table
    evaluations)).

    A state of ``turn0`` with omega1 != 0 reaches its turning point (decelerating: omega1 omega1_dot < 0) after
    |omega1 / omega1_dot|, where the omega1 zero counts, or left it (accelerating) that long ago, uncounted; the
    legs start at that turning point, and every time is shifted by it."""
    n = x0.shape[0]
    p = level.params.as_array()
    rows = np.arange(n)
    b0, w10 = x0[:, 0], x0[:, 1]
    w1dot = np.zeros(n)  # omega1_dot [1/s^2] at the turning point of a turning start (not needed elsewhere)
    if turn0.any():
        w1dot[turn0] = _rates(b0[turn0], np.zeros(int(turn0.sum())), x0[turn0, 2], x0[turn0, 3], p)[1]
    d = np.where(turn0, np.sign(w1dot), np.sign(w10))
    decelerating = w10 * w1dot < 0.0
    with np.errstate(divide="ignore", invalid="ignore"):
        lag = np.where(turn0 & (w10 != 0.0), np.abs(w10 / w1dot), 0.0)
    t_off = np.where(decelerating, lag, -lag)
    counted0 = turn0 & ((w10 == 0.0) | decelerating)
    horizon = t_max - t_off
    res = _Result(x0, t_max)
    A = run_legs(level, rows, b0, d, turn0, d * np.inf, workers)
    res.count(rows, A)
    kA, bA, tA, aA, fA = (A[:, k] for k in (rr.O_KIND, rr.O_BETA, rr.O_T, rr.O_ALPHA, rr.O_FMIN))
    bad = (kA == rr.EV_FAIL) | (kA == rr.EV_CAP)
    res.fail(rows[bad], kA[bad])
    res.fmin[bad] = fA[bad]
    cut = ~bad & (tA > horizon)
    pieces = [(rows[cut], b0[cut], d[cut], turn0[cut], horizon[cut], bA[cut], 0.0, np.inf)]
    fall = ~bad & ~cut & (kA == rr.EV_FALL)
    res.end(rows[fall], bA[fall], d[fall], tA[fall], aA[fall], fA[fall])
    res.fell[fall] = True
    swing = rows[~bad & ~cut & (kA == rr.EV_TURN)]
    pieces += _swings(res, level, swing, b0, d, (turn0, counted0), A, horizon, rtol, workers)
    res.t = np.where(res.failed, 0.0, res.t + t_off)
    for piece in pieces:
        _at_time(res, level, *piece, workers)
    return _finish(res, level, p)


def _swings(res, level, rows, b0, d, starts, A, horizon, rtol, workers):
    """Outcomes of the states ``rows`` whose first leg ends at a turning point b1: the second leg (the other way
    from beta0), then a fall at b2, periodic rolling or the swings up to the horizon [s] (t_max on the legs'
    clock). starts: (turn0, counted0), the states that start on a turning point and those whose start counts as
    an omega1 zero. Returns the pieces of the states cut by the horizon (for ``_at_time``)."""
    n = len(rows)
    b0, d, turn0, counted0, horizon = b0[rows], d[rows], starts[0][rows], starts[1][rows], horizon[rows]
    bA, tA, aA, fA = (A[rows, k] for k in (rr.O_BETA, rr.O_T, rr.O_ALPHA, rr.O_FMIN))
    B = np.zeros((n, rr.N_O))
    B[:, rr.O_KIND] = rr.EV_TURN
    B[:, rr.O_BETA] = b0
    B[:, rr.O_FMIN] = np.inf
    B[:, rr.O_OK] = 1.0
    other = ~turn0
    B[other] = run_legs(level, rows[other], b0[other], -d[other], 0.0, -d[other] * np.inf, workers)
    res.count(rows, B)
    kB, bB, tB, aB, fB = (B[:, k] for k in (rr.O_KIND, rr.O_BETA, rr.O_T, rr.O_ALPHA, rr.O_FMIN))
    bad = (kB == rr.EV_FAIL) | (kB == rr.EV_CAP)
    res.fail(rows[bad], kB[bad])
    res.fmin[rows[bad]] = np.minimum(fA[bad], fB[bad])
    T, swing_alpha, f_both = tA + tB, aA + aB, np.minimum(fA, fB)
    tr_a = _is_transversal(level, rows, bA, rtol)
    tr_b = (kB == rr.EV_TURN) & _is_transversal(level, rows, bB, rtol)
    first = counted0 & tr_b  # the start itself is the first counted omega1 zero
    # the second counted zero: (time, at b1?, half period, alpha); inf: never
    t_end = np.select([first & tr_a, first, tr_a & tr_b, tr_a, tr_b], [tA, tA + T, tA + T, tA + 2 * T, tA + 3 * T],
                      np.inf)
    at_a = np.select([first & tr_a, first, tr_a & tr_b, tr_a], [True, False, False, True], False)
    half = np.select([first & tr_a, first, tr_a & tr_b], [tA, tA + T, T], 2 * T)
    swings = np.select([first & tr_a, first, tr_a & tr_b, tr_a], [0, 1, 1, 2], 3)
    fall = ~bad & (kB == rr.EV_FALL)
    t_end = np.where(fall, tA + T, t_end)
    swings = np.where(fall, 1, swings)
    at_a = at_a & ~fall
    done = ~bad & (t_end <= horizon)
    alpha = aA + swings * swing_alpha
    r, sel = rows[done], done
    res.end(r, np.where(at_a, bA, bB)[sel], np.where(fall, -d, 0.0)[sel], t_end[sel], alpha[sel], f_both[sel])
    res.fell[r] = fall[sel]
    periodic = done & ~fall
    res.outcome[rows[periodic]] = PERIODIC_ROLLING
    res.half[rows[periodic]] = half[periodic]
    cut = ~bad & ~done
    return _cut_swings(rows[cut], b0[cut], d[cut], turn0[cut], bA[cut], bB[cut], A[rows[cut]], B[cut], horizon[cut])


def _cut_swings(rows, b0, d, turn0, bA, bB, A, B, horizon):
    """The pieces in which the horizon [s] falls for the swinging states ``rows`` (see ``_at_time``): k half swings
    of T = t1 + t2 after the first leg, then a part of the next."""
    tA, aA, fA = A[:, rr.O_T], A[:, rr.O_ALPHA], A[:, rr.O_FMIN]
    tB, aB, fB = B[:, rr.O_T], B[:, rr.O_ALPHA], B[:, rr.O_FMIN]
    T = tA + tB
    tau = horizon - tA
    k = np.floor(tau / T)
    rem = np.maximum(tau - k * T, 0.0)
    even = k % 2 == 0
    base = aA + k * (aA + aB)
    seen = np.where(k == 0, fA, np.minimum(fA, fB))  # F2 on the range travelled before the piece
    one = even & (rem <= tA)  # from b1 back towards beta0
    two = even & ~one  # from beta0 on towards b2
    three = ~even & (rem <= tB)  # from b2 back towards beta0
    four = ~even & ~three  # from beta0 on towards b1
    return [(rows[one], bA[one], -d[one], 1.0, rem[one], b0[one], base[one], seen[one]),
            (rows[two], b0[two], -d[two], turn0[two], rem[two] - tA[two], bB[two], base[two] + aA[two], seen[two]),
            (rows[three], bB[three], d[three], 1.0, rem[three], b0[three], base[three], seen[three]),
            (rows[four], b0[four], d[four], turn0[four], rem[four] - tB[four], bA[four], base[four] + aB[four],
             seen[four])]


def _is_transversal(level, rows, beta, rtol):
    """Whether omega1 = 0 at beta [rad] on the levels of ``rows`` is a transversal zero at rtol."""
    w2, w3 = level.spins(rows, beta)
    return np.asarray(_transversal(beta, 0.0, w2, w3, level.params.as_array(), rtol), dtype=bool)


def _at_time(res, level, rows, start, d, sing, target, end, alpha0, seen, workers):
    """Ends the states ``rows`` on the rim at t_max, ``target`` [s] into a piece of monotone motion from ``start``
    towards ``end`` [rad] (direction d, W = 0 at the start where sing; alpha0 [rad] and the smallest F2/m ``seen``
    before it): beta where the piece's time reaches target, by Newton on t(beta) (dt/dbeta = (rho/r) / sqrt(W))
    safeguarded by bisection, each iterate one leg (``run_legs``) stopped there."""
    n = len(rows)
    if n == 0:
        return
    start, d, sing, target, end = (np.broadcast_to(np.asarray(v, dtype=float), (n,)).copy()
                                   for v in (start, d, sing, target, end))
    lo, hi = np.zeros(n), np.abs(end - start)
    s = 0.5 * hi
    todo = np.arange(n)
    last = np.zeros((n, rr.N_O))
    time_scale = level.params.rho / level.params.r
    for _ in range(rr.MAX_NEWTON):
        if todo.size == 0:
            break
        r = rows[todo]
        stop = start[todo] + d[todo] * s[todo]
        legs = run_legs(level, r, start[todo], d[todo], sing[todo], stop, workers)
        res.evals[r] += legs[:, rr.O_EVALS].astype(np.int64)
        last[todo] = legs
        err = legs[:, rr.O_T] - target[todo]
        hi[todo] = np.where(err > 0.0, s[todo], hi[todo])
        lo[todo] = np.where(err > 0.0, lo[todo], s[todo])
        done = (np.abs(err) <= 1e-14 * target[todo] + 1e-16) | (hi[todo] - lo[todo] <= 4e-16 * (np.abs(start[todo])
                                                                                                 + hi[todo]))
        step = -err * np.sqrt(np.maximum(level.w(r, stop), 0.0)) / time_scale
        new = s[todo] + step
        inside = (lo[todo] < new) & (new < hi[todo])
        s[todo] = np.where(inside, new, 0.5 * (lo[todo] + hi[todo]))
        s[todo[done]] = (d[todo] * (stop - start[todo]))[done]
        todo = todo[~done]
    res.status[rows[todo]] = MAX_STEPS
    res.status[rows] = np.where(last[:, rr.O_OK] > 0.0, res.status[rows], MAX_STEPS)
    beta = start + d * s
    res.end(rows, beta, d, res.t_max, alpha0 + last[:, rr.O_ALPHA], np.minimum(seen, last[:, rr.O_FMIN]))


def _finish(res, level, p) -> dict:
    """The columns of ``motions`` from a filled ``_Result``."""
    n = res.t.shape[0]
    rows = np.arange(n)
    end = res.x0.copy()
    ok = ~res.failed
    beta = res.beta[ok]
    w, w2, w3 = level.end_state(rows[ok], beta)
    w1 = res.sign[ok] * np.sqrt(np.maximum(w, 0.0))
    end[ok] = np.stack([beta, w1, w2, w3], axis=-1)
    fell = res.fell
    res.outcome[fell] = fall_outcomes(end[fell, 0], end[fell, 1], end[fell, 3], p)
    fmin = np.where(fell, np.minimum(res.fmin, 0.0), res.fmin)
    return {"t_end": res.t, "f2_min": fmin, "half_period": res.half, "revolutions": res.alpha / (2.0 * np.pi),
            "end": end, "outcome": res.outcome, "status": res.status, "n_steps": res.evals}
