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
