"""Transitions between rolling and slipping (paper Sect. 5.2.2), as pure maps on the state.

Rolling -> slipping: when the friction margin (39) crosses zero downward (or is negative at
the start of a rolling phase), the repelling limit direction phi1 (81) is computed and the slip
velocity is set to u = delta * (cos phi1, sin phi1) (:func:`enter_slipping`).

Slipping -> rolling: trajectories reach u = 0 in finite time along a limit direction phi1 or
phi2 = phi1 + pi. The return is taken (:func:`stop_slip_rate`) when

* the slip speed is small, |u| <= u_stop, and the slip angle phi = atan2(u3, u1) lies within
  phi_tol of the nearer limit direction phi_i, and that direction attracts, u_dot*(x, phi_i)
  < 0 (79); or
* (floor, a progress guarantee) |u| <= u_floor and some limit direction attracts.

Then the remaining time u / (-u_dot*) is extrapolated: the state is advanced by one Euler step
of the slipping equations over that time, u is set to 0 and rolling resumes
(:func:`leave_slipping`). The check runs where |u| crosses u_stop downward (an event located on
the dense output) and at the end of every slipping step with |u| < u_stop.

The tolerances travel to the kernels as a float64 vector indexed by the ``SW_*`` constants, so a
test can halve or double them without recompiling; the defaults are the module constants below.
"""

from __future__ import annotations

import numpy as np

from solver import slipping
from solver._compile import kernel
from solver.params import P_R_BALL, P_R_RIM, P_RHO

DELTA = 1e-6
"""Initial slip speed when slipping starts [m/s] (delta of Sect. 5.2.2)."""
U_STOP = 1e-5
"""Slip speed [m/s] at or below which a slipping ball may return to rolling (10 delta)."""
PHI_TOL = 1e-2
"""Largest angle [rad] between the slip direction and a limit direction for the return."""
U_FLOOR = 1e-7
"""Slip speed [m/s] at or below which the return is taken whatever the slip angle, if a limit
direction attracts (delta / 10): no slipping phase can creep towards u = 0 forever."""

SW_DELTA = 0
SW_U_STOP = 1
SW_PHI_TOL = 2
SW_U_FLOOR = 3
N_SW = 4


def default_tolerances(**changes) -> np.ndarray:
    """The switching-tolerance vector, defaults overridden by keyword (delta, u_stop, phi_tol, u_floor)."""
    values = {"delta": DELTA, "u_stop": U_STOP, "phi_tol": PHI_TOL, "u_floor": U_FLOOR}
    for key, value in changes.items():
        if key not in values:
            raise ValueError(f"unknown switching tolerance `{key}`; allowed: {', '.join(values)}")
        value = float(value)
        if not (np.isfinite(value) and value > 0):
            raise ValueError(f"switching tolerance `{key}` must be a positive finite number; got {value!r}")
        values[key] = value
    out = np.empty(N_SW)
    out[SW_DELTA] = values["delta"]
    out[SW_U_STOP] = values["u_stop"]
    out[SW_PHI_TOL] = values["phi_tol"]
    out[SW_U_FLOOR] = values["u_floor"]
    return out


@kernel
def enter_slipping(y, p, sw):
    """Rolling layout (beta, w1, w2, w3, alpha) -> slipping layout with u = delta e(phi1), in place."""
    phi1 = slipping.limit_direction(y[0], y[1], y[2], y[3], p)
    alpha = y[4]
    y[6] = alpha
    y[4] = sw[SW_DELTA] * np.cos(phi1)
    y[5] = sw[SW_DELTA] * np.sin(phi1)


@kernel
def _wrap(angle):
    """angle wrapped to [-pi, pi)."""
    return (angle + np.pi) % (2.0 * np.pi) - np.pi


@kernel
def stop_slip_rate(y, p, sw):
    """u_dot* (79) [m/s^2] along the limit direction the slip returns by, or 0.0 if no return now.

    A negative value means: return to rolling now (see the module docstring for the rule).
    """
    u1 = y[4]
    u3 = y[5]
    u = np.hypot(u1, u3)
    if u > sw[SW_U_STOP]:
        return 0.0
    phi = np.arctan2(u3, u1)
    phi1 = slipping.limit_direction(y[0], y[1], y[2], y[3], p)
    d1 = abs(_wrap(phi - phi1))
    d2 = abs(_wrap(phi - phi1 - np.pi))
    near = phi1 if d1 <= d2 else phi1 + np.pi
    rate = slipping.radial_slip_rate(y[0], y[1], y[2], y[3], near, p)
    if min(d1, d2) <= sw[SW_PHI_TOL] and rate < 0.0:
        return rate
    if u <= sw[SW_U_FLOOR]:
        far = phi1 + np.pi if d1 <= d2 else phi1
        rate_far = slipping.radial_slip_rate(y[0], y[1], y[2], y[3], far, p)
        best = min(rate, rate_far)
        if best < 0.0:
            return best
    return 0.0


@kernel
def leave_slipping(y, p, rate, t_left):
    """Slipping layout -> rolling layout, in place, after the extrapolated time u / (-rate).

    The time is capped at t_left; the state moves by one Euler step of the slipping equations.
    Returns the time advanced [s].
    """
    u1 = y[4]
    u3 = y[5]
    dt = min(np.hypot(u1, u3) / (-rate), t_left)
    b, d1, d2, d3, _, _ = slipping.slipping_rhs(y[0], y[1], y[2], y[3], u1, u3, p)
    alpha_dot = (u1 - p[P_R_BALL] * y[3]) / (p[P_R_RIM] - p[P_RHO] * np.cos(y[0]))
    alpha = y[6] + dt * alpha_dot
    y[0] += dt * b
    y[1] += dt * d1
    y[2] += dt * d2
    y[3] += dt * d3
    y[4] = alpha
    y[5] = 0.0
    y[6] = 0.0
    return dt
