"""Event location on the dense output: the one place where crossings are found.

Rules (shared by every phase and scene; the event table itself is in ``solver.system``):

* Each event keeps the sign of its last nonzero value. It *fires* when a sample has the
  opposite nonzero sign and that direction counts (direction -1: + to -, +1: - to +, 0: both).
  A value that touches exactly 0 and returns does not fire; a value that starts a phase at 0
  counts as being on the side it must leave (downward events: +), or as unknown (either-way
  events: the first nonzero value sets the sign).
* Signs are compared not only at the two ends of a step but at EVENT_SAMPLES equally spaced
  points of its dense output (theta = k / EVENT_SAMPLES, k = 1..EVENT_SAMPLES; the last is the
  step end itself). This is the guard against a sign change that appears and vanishes inside
  one step (F2 dipping below 0 and back between the step ends), which an end-point check misses.
  The same samples give the running minimum of F2.
* The samples cost a dense-output evaluation and the event functions each; most steps cannot
  contain a crossing, so :func:`may_cross` first decides, from the event values *and their time
  derivatives* at the two step ends (cheap: the slopes are the FSAL stages), whether a sign
  change or a new minimum of F2 is possible at all. It bounds each event function over the step
  by its cubic Hermite interpolant H (values and slopes at both ends) widened by a margin
  GATE_MARGIN_CUBIC |a3| + GATE_MARGIN_SLOPE (|h g'(t)| + |h g'(t + h)|), a3 the cubic
  coefficient of H in theta: the interpolant reproduces a smoothly varying event function up to
  its quartic Taylor term, which over an accepted step is a small fraction of |a3|. Only if
  the widened band reaches zero (or, for F2, an interior trough of H reaches below the running
  minimum of F2) is the step scanned by samples as above; otherwise its end values are taken
  as they are. An event whose slope is not available (NaN) always asks for the scan.
* In the first sub-interval where some events fire, each is located by the Illinois method
  (a safeguarded regula falsi) on the dense output, to a bracket of ROOT_XTOL_EPS machine
  epsilons relative in t; the earliest root wins (ties: lower event index). The returned point
  is the bracket end on the far side of the crossing (or an exact zero), so the event state
  already satisfies the post-event condition and re-detection is impossible.
"""

from __future__ import annotations

import numpy as np

from solver._compile import kernel
from solver.stepper import dense_eval
from solver.system import N_EVENTS, event_values

EVENT_SAMPLES = 4  # sign comparisons per step on the dense output (the guard against grazing)
ROOT_XTOL_EPS = 4.0  # root bracket width, in machine epsilons relative to |t|
ROOT_MAX_ITER = 200  # cap on root-finder iterations (never reached in practice)
GATE_MARGIN_CUBIC = 2.0  # margin of the grazing gate, in units of the Hermite cubic's theta^3 coefficient
GATE_MARGIN_SLOPE = 0.05  # ... plus this fraction of the step's slope terms |h g'| at both ends
_EPS = np.finfo(np.float64).eps


@kernel
def initial_signs(g, direction, sign):
    """Signs of the event values at the start of a phase (see the module rules)."""
    for e in range(N_EVENTS):
        if g[e] > 0.0:
            sign[e] = 1
        elif g[e] < 0.0:
            sign[e] = -1
        else:
            sign[e] = -direction[e]


@kernel
def update_signs(g, sign, skip):
    """Record the sign of every nonzero event value except event ``skip``."""
    for e in range(N_EVENTS):
        if e != skip:
            if g[e] > 0.0:
                sign[e] = 1
            elif g[e] < 0.0:
                sign[e] = -1


@kernel(inline=True)
def _hermite_min(a, b, da, db):
    """Minimum over theta in [0, 1] of the cubic Hermite interpolant of values a, b and theta-slopes da, db.

    Returns (minimum over [0, 1], minimum over interior critical points or +inf, margin of the gate).
    """
    a2 = 3.0 * (b - a) - 2.0 * da - db
    a3 = 2.0 * (a - b) + da + db
    lo = min(a, b)
    interior = np.inf
    # critical points: da + 2 a2 theta + 3 a3 theta^2 = 0
    if a3 == 0.0:
        if a2 != 0.0:
            th = -da / (2.0 * a2)
            if 0.0 < th < 1.0:
                interior = a + th * (da + th * a2)
    else:
        disc = a2 * a2 - 3.0 * a3 * da
        if disc >= 0.0:
            sq = np.sqrt(disc)
            for th in ((-a2 - sq) / (3.0 * a3), (-a2 + sq) / (3.0 * a3)):
                if 0.0 < th < 1.0:
                    interior = min(interior, a + th * (da + th * (a2 + th * a3)))
    margin = GATE_MARGIN_CUBIC * abs(a3) + GATE_MARGIN_SLOPE * (abs(da) + abs(db))
    return min(lo, interior), interior, margin


@kernel(inline=True)
def may_cross(active, sign, g0, r0, g1, r1, h, f2_min):
    """Whether an accepted step [t, t + h] needs the sampled scan (see the module rules).

    g0, r0: event values and their time derivatives at t; g1, r1: at t + h. True when some
    active event may change sign inside the step or at its end, when a slope is not finite, or
    when F2 (event 0) may have an interior trough below ``f2_min``.
    """
    for e in range(N_EVENTS):
        if not active[e]:
            continue
        s = sign[e]
        if s == 0:
            return True
        a = s * g0[e]
        b = s * g1[e]
        if not (a > 0.0 and b > 0.0):
            return True
        da = s * h * r0[e]
        db = s * h * r1[e]
        if not (np.isfinite(da) and np.isfinite(db)):
            return True
        lo, interior, margin = _hermite_min(a, b, da, db)
        if not (lo - margin > 0.0):
            return True
        if e == 0 and s > 0 and interior - margin < f2_min:
            return True
    return False


@kernel
def fires(e, sign, value, active, direction):
    """Whether event e fires at a sample with the given value."""
    if not active[e] or sign[e] == 0 or not (value > 0.0 or value < 0.0):
        return False
    s = 1 if value > 0.0 else -1
    if s == sign[e]:
        return False
    return direction[e] == 0 or direction[e] == s


@kernel
def locate(phase, hybrid, e, a, ga, b, gb, y, h, t0, Q, n, n_poly, p, sw, tmp, gtmp):
    """Root of event e on the dense output in theta in [a, b], ga pre-crossing (or 0), gb post.

    Illinois method; returns the post-crossing bracket end (or an exact zero) once the bracket
    is ROOT_XTOL_EPS epsilons of max(|t0|, |t0 + h|) wide [in units of theta].
    """
    if ga == 0.0:
        return a
    tol = ROOT_XTOL_EPS * _EPS * max(abs(t0), abs(t0 + h), abs(h)) / abs(h)
    side = 0
    for _ in range(ROOT_MAX_ITER):
        if b - a <= tol:
            break
        c = b - gb * (b - a) / (gb - ga)
        if not (c > a and c < b):
            c = 0.5 * (a + b)
            if not (c > a and c < b):
                break
        dense_eval(c, y, h, Q, n, n_poly, tmp)
        event_values(phase, hybrid, tmp, p, sw, gtmp)
        gc = gtmp[e]
        if gc == 0.0:
            return c
        if (gc > 0.0) == (gb > 0.0):
            b = c
            gb = gc
            if side == 1:
                ga *= 0.5
            side = 1
        else:
            a = c
            ga = gc
            if side == -1:
                gb *= 0.5
            side = -1
    return b


@kernel
def scan(phase, hybrid, active, direction, sign, theta0, g0, y, y_new, h, t0, Q, n, n_poly, p, sw,
         y_hi, g_lo, g_hi, tmp, gtmp):
    """Earliest event on the dense output of an accepted step, in theta in (theta0, 1].

    g0: the event values at theta0. Returns (event index or -1, theta of the event or 1.0,
    minimum of F2 (event 0) over the samples before the event). Signs are updated for the stretch scanned
    without an event; with no event, g_hi holds the values at the step end.
    """
    f2min = np.inf
    theta_lo = theta0
    for e in range(N_EVENTS):
        g_lo[e] = g0[e]
        g_hi[e] = g0[e]
    for k in range(1, EVENT_SAMPLES + 1):
        theta_hi = k / EVENT_SAMPLES
        if theta_hi <= theta_lo:
            continue
        if k == EVENT_SAMPLES:
            for i in range(n):
                y_hi[i] = y_new[i]
        else:
            dense_eval(theta_hi, y, h, Q, n, n_poly, y_hi)
        event_values(phase, hybrid, y_hi, p, sw, g_hi)
        best = -1
        best_theta = 2.0
        for e in range(N_EVENTS):
            if fires(e, sign, g_hi[e], active, direction):
                th = locate(phase, hybrid, e, theta_lo, g_lo[e], theta_hi, g_hi[e], y, h, t0, Q, n, n_poly,
                            p, sw, tmp, gtmp)
                if th < best_theta:
                    best = e
                    best_theta = th
        if best >= 0:
            return best, best_theta, f2min
        f2min = min(f2min, g_hi[0])
        update_signs(g_hi, sign, -1)
        for e in range(N_EVENTS):
            g_lo[e] = g_hi[e]
        theta_lo = theta_hi
    return -1, 1.0, f2min
