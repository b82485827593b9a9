"""A slow but simple reference for ``solver.simulate``: scipy ``solve_ivp`` with the same rules.

Rolling-only scenes (mu = inf), conservative or dissipative. Each state is one ``solve_ivp``
call on the rolling equations (plus alpha) with two scipy events: F2 (31) crossing zero
downward (terminal) and, in conservative scenes, omega1 crossing zero (terminal at its second
occurrence). Then DESIGN §4: F2 < 0 at t = 0 falls at once; a fall is classified by the free
flight of ``solver.flight``; two omega1 crossings give ``periodic_rolling`` with
half_period = t2 - t1; otherwise the ball is on the rim at t_max.

scipy looks for sign changes only at step ends, so an F2 dip below zero inside one step is
missed (scipy issue #9228). The reference therefore also samples F2 on the dense output,
GRAZE_SAMPLES points per step, and takes the first downward crossing found there (located by
``brentq``) as the fall if it comes before the end scipy reported.

Used by the tests and by the work-precision study as the independent baseline.
"""

from __future__ import annotations

import numpy as np
from scipy.integrate import solve_ivp
from scipy.optimize import brentq

from solver import flight, kinematics, rolling
from solver.outcomes import ON_RIM_AT_T_MAX, PERIODIC_ROLLING
from solver.params import Params


GRAZE_SAMPLES = 32


def _first_missed_dip(sol, F2, t_end):
    """Earliest downward zero of F2 on the dense output in (0, t_end), or None."""
    for t0, t1 in zip(sol.t[:-1], sol.t[1:]):
        if t0 >= t_end:
            break
        ts = np.linspace(t0, min(t1, t_end), GRAZE_SAMPLES + 1)
        g = np.array([F2(sol.sol(t)) for t in ts])
        down = np.flatnonzero((g[:-1] > 0) & (g[1:] < 0))
        if down.size:
            k = down[0]
            return brentq(lambda t: F2(sol.sol(t)), ts[k], ts[k + 1], xtol=1e-15, rtol=4 * np.finfo(float).eps)
    return None


def reference_one(state, params: Params, t_max=20.0, rtol=1e-11, atol=1e-12, method="DOP853"):
    """Outcome of one rolling initial state by ``solve_ivp``: dict(outcome, t_end, half_period, nfev)."""
    if not params.rolling_only:
        raise NotImplementedError("the scipy reference covers rolling-only scenes (mu = inf)")
    p = params.as_array()
    rhs = rolling.rolling_rhs.py_func
    F2 = rolling.normal_force.py_func

    def fun(t, y):
        b, w1, w2, w3 = rhs(y[0], y[1], y[2], y[3], p)
        alpha_dot, _ = kinematics.angle_rates.py_func(y[0], y[1], y[3], 0.0, 0.0, p)
        return [b, w1, w2, w3, alpha_dot]

    def fall(t, y):
        return F2(y[0], y[1], y[3], p)

    fall.terminal = True
    fall.direction = -1

    def omega1_zero(t, y):
        return y[1]

    omega1_zero.terminal = 2
    omega1_zero.direction = 0

    y0 = np.array([*np.asarray(state, float), 0.0])
    if fall(0.0, y0) < 0:
        return {"outcome": int(flight.flight_outcome.py_func(y0[0], y0[1], y0[3], 0.0, 0.0, p)),
                "t_end": 0.0, "half_period": np.nan, "nfev": 0}
    events = [fall] if params.dissipative else [fall, omega1_zero]
    sol = solve_ivp(fun, (0.0, t_max), y0, method=method, rtol=rtol, atol=atol, events=events, dense_output=True)
    t_fall = sol.t_events[0]
    t_w1 = sol.t_events[1] if len(events) > 1 else np.empty(0)
    t_dip = _first_missed_dip(sol, lambda y: fall(0.0, y), float(sol.t[-1]))
    if t_dip is not None and not (t_fall.size and t_fall[0] <= t_dip):
        y = sol.sol(t_dip)
        outcome = int(flight.flight_outcome.py_func(y[0], y[1], y[3], 0.0, 0.0, p))
        return {"outcome": outcome, "t_end": float(t_dip), "half_period": np.nan, "nfev": sol.nfev}
    if t_fall.size and (t_w1.size < 2 or t_fall[0] <= t_w1[1]):
        y = sol.y_events[0][0]
        outcome = int(flight.flight_outcome.py_func(y[0], y[1], y[3], 0.0, 0.0, p))
        return {"outcome": outcome, "t_end": float(t_fall[0]), "half_period": np.nan, "nfev": sol.nfev}
    if t_w1.size >= 2:
        return {"outcome": PERIODIC_ROLLING, "t_end": float(t_w1[1]), "half_period": float(t_w1[1] - t_w1[0]),
                "nfev": sol.nfev}
    return {"outcome": ON_RIM_AT_T_MAX, "t_end": float(sol.t[-1]), "half_period": np.nan, "nfev": sol.nfev}


def reference(states, params: Params, t_max=20.0, rtol=1e-11, atol=1e-12, method="DOP853"):
    """``reference_one`` over an array (..., 4) of states: dict of arrays (outcome, t_end, half_period, nfev)."""
    x = np.asarray(states, float)
    flat = x.reshape(-1, 4)
    rows = [reference_one(s, params, t_max, rtol, atol, method) for s in flat]
    shape = x.shape[:-1]
    return {
        "outcome": np.array([r["outcome"] for r in rows], dtype=np.int8).reshape(shape),
        "t_end": np.array([r["t_end"] for r in rows]).reshape(shape),
        "half_period": np.array([r["half_period"] for r in rows]).reshape(shape),
        "nfev": np.array([r["nfev"] for r in rows]).reshape(shape),
    }
