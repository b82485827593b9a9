"""Event location on the dense output of an accepted step: the one place where events are found.

The locator knows no physics: it is handed the event function of a phase as a compiled function
``events(y, f, p, event_tol, g, gr)`` (values of every event at state y into g, their time
derivatives along the rates f into gr, NaN where not available) and the phase's event table
(``direction``, ``track_min``, ``active`` arrays; see ``solver.engine.system``).

Rules, shared by every phase and scene:

* Each event keeps the sign of its last nonzero value. It *fires* when a value has the opposite
  nonzero sign and that direction counts (direction -1: + to -, +1: - to +, 0: both). A value
  that touches exactly 0 and returns does not fire; a value that starts a phase at 0 counts as
  being on the side it must leave (downward events: +), or as unknown (either-way events: the
  first nonzero value sets the sign).
* **Sign changes at the step end** are located on the dense output by a safeguarded Newton method
  (each evaluation gives the event's time derivative along the dense output too; the Illinois
  method, a safeguarded regula falsi, where a Newton point would leave the bracket or there is no
  derivative), to a bracket of ROOT_XTOL_EPS machine epsilons relative in t.
  The returned point is the bracket end on the far side of the crossing (or an exact zero), so
  the event state already satisfies the post-event condition and re-detection is impossible.
* **Tracked minima** (``track_min``: F2). A dip below zero that is over before the step ends
  leaves both ends positive. So the event is decided at the *minimum* of the event function
  inside the step: whenever the gate below says a trough below zero (or below the running
  minimum) is possible, the minimum is located on the dense output (Brent's method, started at
  the critical point of the Hermite cubic, to MIN_XTOL in theta); if the value there is <= 0
  the event fires, at the first zero before the minimum.
* **The gate** (:func:`trough_possible`) costs nothing extra: the cubic Hermite interpolant H of
  the event function g on the step (values and slopes at both ends: the slopes come from the
  first-same-as-last stage) differs from g by g''''(xi) h^4 theta^2 (1 - theta)^2 / 24, at
  most h^4 max|g''''| / 384. max|g''''| is estimated by the divided difference of the constant
  third derivatives of H on this step and on the previous one, |g'''_k - g'''_{k-1}| /
  ((h_k + h_{k-1}) / 2), times GATE_SAFETY for its variation across the two steps; the dense
  output's own error adds rtol (|g(t)| + |g(t + h)|). If H minus that bound stays positive
  (and above the running minimum), no zero and no new minimum is possible and the step is not
  searched. On the first step of a phase (no previous cubic) the remainder is measured instead:
  g is evaluated on the dense output at the midpoint, where the remainder of a constant fourth
  derivative peaks, and GATE_SAFETY times |g - H| there is the bound.
* A step whose end value already fires, with H monotone over the step (no interior trough), is
  not searched for a minimum: the crossing is located directly.
* **Events without a derivative** (the friction margin (39)) cannot be gated: their sign is
  compared at EVENT_SAMPLES equally spaced points of every step's dense output.
* The earliest event of the step wins (ties: lower event index).
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np

from rimroll.solver._compile import engine_kernel
from rimroll.solver.engine.stepper import dense_eval, dense_slope

EVENT_SAMPLES = 4  # sign comparisons per step for events without a derivative
ROOT_XTOL_EPS = 4.0  # root bracket width, in machine epsilons relative to |t|
ROOT_MAX_ITER = 200  # cap on root-finder iterations (never reached in practice)
MIN_XTOL = 1e-9  # the minimum of a tracked event is located to this width in theta
MIN_MAX_ITER = 100  # cap on Brent iterations
GATE_SAFETY = 2.0  # factor on the estimated max|g''''| (its variation over two steps)
_EPS = np.finfo(np.float64).eps
_GOLDEN = 0.3819660112501051  # (3 - sqrt(5)) / 2


class Dense(NamedTuple):
    """The dense output of one accepted step: the step's start state y, length h [s], start time
    t0 [s], the coefficients Q of ``stepper.dense_prepare`` and the number n of live components."""

    y: np.ndarray
    h: float
    t0: float
    Q: np.ndarray
    n: int


class Scratch(NamedTuple):
    """Scratch arrays of the locator: a state and its slope, event values and rates, and the event
    values at the two ends of a sampled interval."""

    tmp: np.ndarray
    slope: np.ndarray
    g: np.ndarray
    gr: np.ndarray
    g_lo: np.ndarray
    g_hi: np.ndarray


class Tracking(NamedTuple):
    """What the locator keeps of each event along a phase: its sign, whether the gate asks for its
    minimum in this step (``search``), where to start looking (``th_min``) and its running minimum."""

    sign: np.ndarray
    search: np.ndarray
    th_min: np.ndarray
    mins: np.ndarray


@engine_kernel
def initial_signs(g, direction, sign):
    """Signs of the event values at the start of a phase (see the module rules)."""
    for e in range(g.shape[0]):
        if g[e] > 0.0:
            sign[e] = 1
        elif g[e] < 0.0:
            sign[e] = -1
        else:
            sign[e] = -direction[e]


@engine_kernel
def update_signs(g, sign, skip):
    """Record the sign of every nonzero event value except event ``skip``."""
    for e in range(g.shape[0]):
        if e != skip:
            if g[e] > 0.0:
                sign[e] = 1
            elif g[e] < 0.0:
                sign[e] = -1


@engine_kernel
def fires(e, sign, value, active, direction):
    """Whether event e fires at a state where its value is ``value``."""
    if not active[e] or sign[e] == 0 or not (value > 0.0 or value < 0.0):
        return False
    s = 1 if value > 0.0 else -1
    if s == sign[e]:
        return False
    return direction[e] == 0 or direction[e] == s


@engine_kernel(inline=True)
def hermite_coefficients(a, b, da, db):
    """(a2, a3) of the cubic Hermite interpolant a + da theta + a2 theta^2 + a3 theta^3 on [0, 1]
    with values a, b and theta-slopes da, db at its ends."""
    return 3.0 * (b - a) - 2.0 * da - db, 2.0 * (a - b) + da + db


@engine_kernel(inline=True)
def hermite(a, b, da, db):
    """The cubic Hermite interpolant on theta in [0, 1] of values a, b and theta-slopes da, db.

    Returns (its minimum over [0, 1], the theta of that minimum, its cubic coefficient a3).
    """
    a2, a3 = hermite_coefficients(a, b, da, db)
    lo = a
    th_lo = 0.0
    if b < lo:
        lo = b
        th_lo = 1.0
    # critical points: da + 2 a2 theta + 3 a3 theta^2 = 0
    if a3 == 0.0:
        if a2 != 0.0:
            th = -da / (2.0 * a2)
            if 0.0 < th < 1.0:
                v = a + th * (da + th * a2)
                if v < lo:
                    lo = v
                    th_lo = th
    else:
        disc = a2 * a2 - 3.0 * a3 * da
        if disc >= 0.0:
            sq = np.sqrt(disc)
            for th in ((-a2 - sq) / (3.0 * a3), (-a2 + sq) / (3.0 * a3)):
                if 0.0 < th < 1.0:
                    v = a + th * (da + th * (a2 + th * a3))
                    if v < lo:
                        lo = v
                        th_lo = th
    return lo, th_lo, a3


@engine_kernel(inline=True)
def trough_possible(g0, r0, g1, r1, h, h_prev, third_prev, mid_err, rtol):
    """The gate of a tracked event on a step of length h [s] (see the module rules).

    g0, r0: value and time derivative at the step start; g1, r1: at its end; h_prev, third_prev:
    the previous step's length and the third derivative of its Hermite cubic (NaN: none, the
    first step of a phase); mid_err: |g - H| at the step's midpoint on the dense output, used
    only when there is no previous step (then the remainder, which peaks at the midpoint for a
    constant fourth derivative, is bounded by GATE_SAFETY * mid_err).
    Returns (search, lowest value of the Hermite cubic H on the step, the theta where H is
    lowest, the third derivative of H [units/s^3]). ``search`` is True when the event function
    may reach <= 0 inside the step (H minus the error bound) or a derivative is not finite.
    """
    if not (np.isfinite(r0) and np.isfinite(r1)):
        return True, min(g0, g1), 0.5, np.nan
    lo, th_lo, a3 = hermite(g0, g1, h * r0, h * r1)
    third = 6.0 * a3 / (h * h * h)
    if np.isfinite(third_prev):
        m4 = GATE_SAFETY * abs(third - third_prev) / (0.5 * (h + h_prev))
        bound = h * h * h * h * m4 / 384.0
    else:
        bound = GATE_SAFETY * mid_err
    margin = bound + rtol * (abs(g0) + abs(g1))
    return not (lo - margin > 0.0), lo, th_lo, third


@engine_kernel
def hermite_at(g0, r0, g1, r1, h, theta):
    """The cubic Hermite interpolant of values g0, g1 and time derivatives r0, r1 on a step of
    length h [s], at theta in [0, 1]."""
    da = h * r0
    a2, a3 = hermite_coefficients(g0, g1, da, h * r1)
    return g0 + theta * (da + theta * (a2 + theta * a3))


@engine_kernel(takes_functions=True)
def value_at(events, e, theta, dense, p, event_tol, scratch):
    """Value of event e on the dense output at theta (the state into scratch.tmp, its slope into
    scratch.slope, every event's value and rate into scratch.g, scratch.gr)."""
    n_poly = dense.Q.shape[1]
    dense_eval(theta, dense.y, dense.h, dense.Q, dense.n, n_poly, scratch.tmp)
    dense_slope(theta, dense.Q, dense.n, n_poly, scratch.slope)
    events(scratch.tmp, scratch.slope, p, event_tol, scratch.g, scratch.gr)
    return scratch.g[e]


@engine_kernel(takes_functions=True)
def locate(events, e, a, ga, b, gb, dense, p, event_tol, scratch):
    """Root of event e on the dense output in theta in [a, b], ga pre-crossing (or 0), gb post.

    Safeguarded Newton: each evaluation of the event on the dense output also gives its time
    derivative along the dense output (``scratch.gr``, exact for the interpolant), so the next point
    is the Newton point where it falls inside the bracket, else the Illinois point (a safeguarded
    regula falsi; always for an event without a finite derivative). Once a Newton step is shorter
    than the tolerance, the next point is put just across the root, so that the bracket closes from
    both sides. Returns the post-crossing bracket end (or an exact zero) once the bracket is
    ROOT_XTOL_EPS epsilons of max(|t0|, |t0 + h|) wide [in units of theta].
    """
    if ga == 0.0:
        return a
    t0 = dense.t0
    h = dense.h
    tol = ROOT_XTOL_EPS * _EPS * max(abs(t0), abs(t0 + h), abs(h)) / abs(h)
    side = 0
    c = b - gb * (b - a) / (gb - ga)
    for _ in range(ROOT_MAX_ITER):
        if b - a <= tol:
            break
        if not (c > a and c < b):
            c = 0.5 * (a + b)
            if not (c > a and c < b):
                break
        gc = value_at(events, e, c, dense, p, event_tol, scratch)
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
        slope = h * scratch.gr[e]  # d(event)/d(theta) at c
        step = -gc / slope if slope != 0.0 and np.isfinite(slope) else np.nan
        if abs(step) < 0.5 * tol:  # converged from one side: the next point just across the root
            step = 0.5 * tol if c == a else -0.5 * tol
        newton = c + step
        if newton > a and newton < b:
            c = newton
        else:
            c = b - gb * (b - a) / (gb - ga)
    return b


@engine_kernel(takes_functions=True)
def minimum(events, e, a, b, start, sgn, dense, p, event_tol, scratch):
    """Local minimum of sgn * (event e) on the dense output over theta in [a, b], from ``start``.

    Brent's method (golden section with parabolic steps; Brent, Algorithms for Minimization
    without Derivatives, 1973, ch. 5), to MIN_XTOL in theta. Returns (theta, sgn * value there);
    the end values are compared too, so a minimum at an end of [a, b] is found as well.
    """
    x = min(max(start, a), b)
    fx = sgn * value_at(events, e, x, dense, p, event_tol, scratch)
    w = x
    v = x
    fw = fx
    fv = fx
    d = 0.0
    step = 0.0
    lo = a
    hi = b
    for _ in range(MIN_MAX_ITER):
        mid = 0.5 * (lo + hi)
        tol1 = MIN_XTOL * 0.5 + _EPS * abs(x)
        tol2 = 2.0 * tol1
        if abs(x - mid) <= tol2 - 0.5 * (hi - lo):
            break
        parabolic = False
        if abs(step) > tol1:
            rr = (x - w) * (fx - fv)
            qq = (x - v) * (fx - fw)
            pp = (x - v) * qq - (x - w) * rr
            qq = 2.0 * (qq - rr)
            if qq > 0.0:
                pp = -pp
            qq = abs(qq)
            if abs(pp) < abs(0.5 * qq * step) and pp > qq * (lo - x) and pp < qq * (hi - x):
                step = d
                d = pp / qq
                u = x + d
                if u - lo < tol2 or hi - u < tol2:
                    d = tol1 if mid >= x else -tol1
                parabolic = True
        if not parabolic:
            step = (lo - x) if x >= mid else (hi - x)
            d = _GOLDEN * step
        u = x + d if abs(d) >= tol1 else x + (tol1 if d > 0.0 else -tol1)
        fu = sgn * value_at(events, e, u, dense, p, event_tol, scratch)
        if fu <= fx:
            if u >= x:
                lo = x
            else:
                hi = x
            v = w
            fv = fw
            w = x
            fw = fx
            x = u
            fx = fu
        else:
            if u < x:
                lo = u
            else:
                hi = u
            if fu <= fw or w == x:
                v = w
                fv = fw
                w = u
                fw = fu
            elif fu <= fv or v == x or v == w:
                v = u
                fv = fu
    for th in (a, b):
        f_end = sgn * value_at(events, e, th, dense, p, event_tol, scratch)
        if f_end < fx:
            x = th
            fx = f_end
    return x, fx


@engine_kernel(takes_functions=True)
def next_event(events, table, tracking, theta0, g0, g1, gr1, dense, p, event_tol, scratch):
    """Earliest event of an accepted step in theta in (theta0, 1] (see the module rules).

    ``table``: the phase's event table (``active``, ``direction``, ``track_min`` arrays);
    ``tracking``: a :class:`Tracking` (``search[e]``: the gate asks for the minimum of tracked
    event e, ``th_min[e]``: where to start looking; ``mins[e]`` is lowered to a minimum found that
    does not fire); g0: event values at theta0; g1, gr1: values and derivatives at the step end
    (theta = 1). Returns (event index or -1, theta of the event, or 1.0). With no event, the signs
    are updated to the step end.
    """
    best, best_theta = _tracked_minima(events, table, tracking, theta0, g0, dense, p, event_tol, scratch)
    # sign changes at the step end
    for e in range(g0.shape[0]):
        if fires(e, tracking.sign, g1[e], table.active, table.direction):
            root = locate(events, e, theta0, g0[e], 1.0, g1[e], dense, p, event_tol, scratch)
            if root < best_theta or (root == best_theta and e < best):
                best = e
                best_theta = root
    # events without a derivative (not gated): sign comparisons at samples inside the step
    sampled = False
    for e in range(g0.shape[0]):
        if table.active[e] and not np.isfinite(gr1[e]):
            sampled = True
    if sampled:
        e, theta = _sampled(events, table, tracking.sign, theta0, g0, gr1, best_theta, dense, p, event_tol, scratch)
        if e >= 0:
            best = e
            best_theta = theta
    if best < 0:
        update_signs(g1, tracking.sign, np.int64(-1))  # int64, not Literal[int]: one compiled callee
        return -1, 1.0
    return best, best_theta


@engine_kernel(inline=True, takes_functions=True)
def _tracked_minima(events, table, tracking, theta0, g0, dense, p, event_tol, scratch):
    """Tracked events the gate asks about: the event is decided at its minimum over (theta0, 1].
    Returns (the earliest firing event or -1, its theta or 2.0)."""
    best = -1
    best_theta = 2.0
    sign = tracking.sign
    for e in range(g0.shape[0]):
        if not (table.active[e] and table.track_min[e] and tracking.search[e]):
            continue
        sgn = -1.0 if sign[e] < 0 else 1.0
        th, val = minimum(events, e, theta0, 1.0, max(tracking.th_min[e], theta0), sgn, dense, p, event_tol,
                          scratch)
        gm = sgn * val
        if fires(e, sign, gm, table.active, table.direction):
            root = theta0
            if th > theta0:
                root = locate(events, e, theta0, g0[e], th, gm, dense, p, event_tol, scratch)
            if root < best_theta:
                best = e
                best_theta = root
        elif sign[e] > 0 and gm < tracking.mins[e]:
            tracking.mins[e] = gm
    return best, best_theta


@engine_kernel(inline=True, takes_functions=True)
def _sampled(events, table, sign, theta0, g0, gr1, limit, dense, p, event_tol, scratch):
    """Events without a derivative: their signs compared at EVENT_SAMPLES points of the step before
    theta = limit. Returns the earliest event firing before limit and its theta, or (-1, limit)."""
    best = -1
    best_theta = limit
    g_lo = scratch.g_lo
    g_hi = scratch.g_hi
    n_ev = g0.shape[0]
    n_poly = dense.Q.shape[1]
    for e in range(n_ev):
        g_lo[e] = g0[e]
    th_lo = theta0
    for k in range(1, EVENT_SAMPLES):
        th_hi = k / EVENT_SAMPLES
        if th_hi <= th_lo:
            continue
        if th_hi >= best_theta:
            break
        dense_eval(th_hi, dense.y, dense.h, dense.Q, dense.n, n_poly, scratch.tmp)
        dense_slope(th_hi, dense.Q, dense.n, n_poly, scratch.slope)
        events(scratch.tmp, scratch.slope, p, event_tol, g_hi, scratch.gr)
        hit = False
        for e in range(n_ev):
            if table.active[e] and not np.isfinite(gr1[e]) and fires(e, sign, g_hi[e], table.active,
                                                                      table.direction):
                root = locate(events, e, th_lo, g_lo[e], th_hi, g_hi[e], dense, p, event_tol, scratch)
                if root < best_theta:
                    best = e
                    best_theta = root
                    hit = True
        if hit:
            break
        for e in range(n_ev):
            if table.active[e] and not np.isfinite(gr1[e]):
                g_lo[e] = g_hi[e]
                if g_hi[e] > 0.0:
                    sign[e] = 1
                elif g_hi[e] < 0.0:
                    sign[e] = -1
        th_lo = th_hi
    return best, best_theta
