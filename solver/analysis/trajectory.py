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

from typing import NamedTuple

import numpy as np
from scipy.integrate import solve_ivp

from rimroll.solver._arguments import finite_array, real_array
from rimroll.solver.physics import rolling
from rimroll.solver.physics.params import Params

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
    t_eval = real_array("t_eval", t_eval)
    if t_eval.ndim != 1:
        raise ValueError(f"`t_eval` must be 1-D; got shape {t_eval.shape}")
    finite_array("t_eval", t_eval)  # a NaN time has no state
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


class Scan(NamedTuple):
    """What :func:`scan` saw along the rolling solution through x0 (times in s, states (k, 4))."""

    sol: object
    """scipy ``OdeSolution``: the dense output x(t) on [0, t_end] (``sol(t)`` -> (4,) or (4, n))."""
    t_end: float
    zero_times: np.ndarray
    """zeros of omega1 in (0, t_end], ascending (a zero at t = 0 itself is not reported)."""
    zero_states: np.ndarray
    return_times: np.ndarray
    """times in (0, t_end] at which beta = beta(0) + 2 pi k, k != 0 (one revolution of the
    ball over the rim's cross-section each)."""
    return_states: np.ndarray
    status: int
    """0 when the integration reached the n-th zero or t_max, -1 when it failed."""


def scan(x0, p: Params, t_max: float, n_zeros: int | None = 2, rtol: float = DEFAULT_RTOL,
         atol: float = DEFAULT_ATOL) -> Scan:
    """Integrate the rolling solution through x0 up to the ``n_zeros``-th zero of omega1 or t_max [s].

    DOP853 at rtol/atol with dense output; the zeros of omega1 and the returns of beta to
    beta(0) mod 2 pi are located on the dense output (scipy events, to ~rtol). ``n_zeros=None``
    never stops at a zero. A failed integration is reported in ``status`` with what was found.
    """
    x0 = _check_state(x0)
    rhs = _rhs(p.as_array())
    beta0 = float(x0[0])

    def zero(t, x):
        return x[1]

    def revolution(t, x):
        return np.sin(0.5 * (x[0] - beta0))

    # scipy reports a zero at t = 0 as an event when omega1(0) = 0 exactly: allow for it
    at_zero = x0[1] == 0.0
    zero.terminal = 0 if n_zeros is None else int(n_zeros) + int(at_zero)
    sol = solve_ivp(rhs, (0.0, float(t_max)), x0, method="DOP853", rtol=rtol, atol=atol,
                    events=[zero, revolution], dense_output=True)
    floor = 1e-12 * max(1.0, float(t_max))
    times, states = (np.asarray(v, dtype=float) for v in (sol.t_events[0], sol.y_events[0]))
    states = states.reshape(-1, 4)
    keep = times > (floor if at_zero else 0.0)
    times, states = times[keep], states[keep]
    if n_zeros is not None:
        times, states = times[:n_zeros], states[:n_zeros]
    r_times, r_states = (np.asarray(v, dtype=float) for v in (sol.t_events[1], sol.y_events[1]))
    r_states = r_states.reshape(-1, 4)
    keep = np.abs(r_states[:, 0] - beta0) > np.pi  # not beta(0) itself, where a swing turns back
    return Scan(sol.sol, float(sol.t[-1]), times, states, r_times[keep], r_states[keep],
                0 if sol.status >= 0 else -1)


def omega1_zeros(x0, p: Params, t_max: float, n_zeros: int = 2, rtol: float = DEFAULT_RTOL,
                 atol: float = DEFAULT_ATOL, *, with_states: bool = False):
    """The first ``n_zeros`` zeros of omega1(t) in (0, t_max] along the rolling solution through x0.

    Returns (times [s], omega1_dot at those times [1/s^2], status), and the states at the zeros
    (shape (k, 4)) as a fourth item if ``with_states``: times ascending, located on
    DOP853's dense output (scipy event, to ~rtol); status 0 when the integration reached the
    n-th zero or t_max, -1 when it failed (then the zeros found so far are returned).
    A zero at t = 0 itself (omega1(0) = 0) is not reported: the caller knows it.
    """
    found = scan(x0, p, t_max, n_zeros=n_zeros, rtol=rtol, atol=atol)
    p_array = p.as_array()
    rates = np.array([rolling.rolling_rhs(*s, p_array)[1] for s in found.zero_states])
    if with_states:
        return found.zero_times, rates, found.status, found.zero_states
    return found.zero_times, rates, found.status
