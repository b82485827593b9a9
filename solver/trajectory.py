"""High-accuracy trajectories of the rolling equations (33)-(36) (with (83)) WITHOUT falling or slipping.

These integrate the rolling ODE as a mathematical system (paper Sect. 4: "the slipping
condition (39) and the falling condition (40) are not considered"), with scipy's DOP853 and
the compiled right-hand side :func:`solver.rolling.rolling_rhs`. They serve the global-dynamics
studies (Theorem 1, conserved quantities) on a few hundred states; for outcome maps with
falling and slipping use ``solver.simulate``.

State x = (beta [rad], omega1, omega2, omega3 [1/s]); ``p`` a :class:`solver.Params`
(mu is ignored: the ball never slips here, F2 is never checked).
"""

from __future__ import annotations

import numpy as np
from scipy.integrate import solve_ivp

from solver import rolling
from solver.params import Params

DEFAULT_RTOL = 1e-10
DEFAULT_ATOL = 1e-12


def _rhs(p_array):
    f = rolling.rolling_rhs

    def rhs(t, x):
        return np.array(f(x[0], x[1], x[2], x[3], p_array))

    return rhs


def _check_state(x0) -> np.ndarray:
    x0 = np.asarray(x0, dtype=float)
    if x0.shape != (4,):
        raise ValueError(f"x0 must have shape (4,) = (beta, omega1, omega2, omega3); got {x0.shape}")
    if not np.all(np.isfinite(x0)):
        raise ValueError(f"x0 must be finite; got {x0}")
    return x0


def rolling_trajectory(x0, p: Params, t_eval, rtol: float = DEFAULT_RTOL, atol: float = DEFAULT_ATOL):
    """The rolling solution through x0 at the times t_eval [s]: array (len(t_eval), 4).

    t_eval: 1-D, sorted (increasing, or decreasing for backward time), starting anywhere; the
    integration runs from t = 0 (where x = x0) through every t_eval with scipy DOP853
    (dense output) at rtol/atol. A failed integration raises RuntimeError with scipy's message.
    """
    x0 = _check_state(x0)
    t_eval = np.asarray(t_eval, dtype=float)
    if t_eval.ndim != 1:
        raise ValueError("t_eval must be 1-D")
    out = np.empty((t_eval.size, 4))
    if t_eval.size == 0:
        return out
    rhs = _rhs(p.as_array())
    for sign in (1.0, -1.0):  # forward for t >= 0, backward for t < 0
        sel = (t_eval >= 0) if sign > 0 else (t_eval < 0)
        if not np.any(sel):
            continue
        t_end = float(np.max(sign * t_eval[sel])) * sign
        if t_end == 0.0:
            out[sel] = x0
            continue
        sol = solve_ivp(rhs, (0.0, t_end), x0, method="DOP853", rtol=rtol, atol=atol, dense_output=True)
        if sol.status < 0:
            raise RuntimeError(f"rolling_trajectory failed from x0={x0}: {sol.message}")
        out[sel] = sol.sol(t_eval[sel]).T
    return out


def omega1_zeros(x0, p: Params, t_max: float, n_zeros: int = 2, rtol: float = DEFAULT_RTOL,
                 atol: float = DEFAULT_ATOL, *, with_states: bool = False):
    """The first ``n_zeros`` zeros of omega1(t) in (0, t_max] along the rolling solution through x0.

    Returns (times [s], omega1_dot at those times [1/s^2], status), and the states at the zeros
    (shape (k, 4)) as a fourth item if ``with_states``: times ascending, located on
    DOP853's dense output (scipy event, to ~rtol); status 0 when the integration reached the
    n-th zero or t_max, -1 when it failed (then the zeros found so far are returned).
    A zero at t = 0 itself (omega1(0) = 0) is not reported: the caller knows it.
    """
    x0 = _check_state(x0)
    p_array = p.as_array()
    rhs = _rhs(p_array)

    def event(t, x):
        return x[1]

    # scipy reports a zero at t = 0 as an event when omega1(0) = 0 exactly: allow for it
    at_zero = x0[1] == 0.0
    event.terminal = int(n_zeros) + int(at_zero)
    sol = solve_ivp(rhs, (0.0, float(t_max)), x0, method="DOP853", rtol=rtol, atol=atol, events=event)
    times = np.asarray(sol.t_events[0], dtype=float)
    states = np.asarray(sol.y_events[0], dtype=float).reshape(-1, 4)
    keep = times > (1e-12 * max(1.0, float(t_max)) if at_zero else 0.0)
    times, states = times[keep][:n_zeros], states[keep][:n_zeros]
    rates = np.array([rolling.rolling_rhs(*s, p_array)[1] for s in states])
    status = 0 if sol.status >= 0 else -1
    if with_states:
        return times, rates, status, states
    return times, rates, status
