"""Transitions between rolling and slipping (paper Sect. 5.2.2), as pure maps on the state.

Rolling -> slipping: when the friction margin (39) crosses zero downward (or is negative at
the start of a rolling phase), the repelling limit direction phi1 (81) is computed and the slip
velocity is set to u = delta * (cos phi1, sin phi1) (:func:`enter_slipping`).

Slipping -> rolling: trajectories reach u = 0 in finite time along a limit direction phi1 or
phi2 = phi1 + pi. The return is taken (:func:`stop_slip_rate`) when

* the slip speed is small, |u| <= u_stop, and the slip angle phi = atan2(u3, u1) lies within
  phi_tol of the nearer limit direction phi_i, and that direction attracts, u_dot*(x, phi_i)
  < 0 (79); or
* (floor, a progress guarantee) |u| <= u_floor and some limit direction attracts;

and, in both cases, the remaining time u / (-u_dot*) is at most dt_max. The state is then
advanced by one Euler step of the slipping equations over that time, u is set to 0
(:func:`leave_slipping`), and rolling resumes, unless the slip came back along phi1 and the
rolling state is not strictly inside the friction cone (39): rolling would at once slip again
along the same direction, so the return is refused and slipping goes on (no chattering on the
cone's boundary). Returning along phi2 while phi1 repels is a slip reversal: rolling resumes
and slips at once along phi1, as the algorithm of Sect. 5.2.2 prescribes. The check runs where |u| crosses u_stop
downward (an event located on
the dense output) and at the end of every slipping step with |u| < u_stop.

The tolerances travel to the kernels as a float64 vector indexed by the ``SW_*`` constants, so a
test can halve or double them without recompiling; the defaults are the module constants below.
"""

from __future__ import annotations

import numpy as np

from rimroll.solver._compile import engine_kernel
from rimroll.solver.physics import kinematics, loads, rolling, slipping
from rimroll.solver.physics.params import P_J, P_M, P_R_BALL

DELTA = 1e-5
"""Initial slip speed when slipping starts [m/s] (delta of Sect. 5.2.2), set by a contact impulse.

Why this size: the paper's model is the limit delta -> 0; the launch perturbs the trajectory by
O(delta) (on 656 slipping states of Fig. 12 at rtol 1e-10: median |t_end change| against delta =
1e-8 of 3e-7 s at 1e-5, 3e-9 s at 1e-7; no outcome changed from 1e-4 to 1e-8) and the energy by
(1/2) j m delta^2/(1+j) only (see enter_slipping). While the slip is small the slipping equations
are stiff (the slip angle relaxes at |B|/u); with explicit steps the cost grew as delta shrank
(860 steps per slipping lane at 1e-6, 370 at 1e-5), with the engine's Rosenbrock steps it hardly
does (342 .. 375 steps per slip from 1e-4 to 1e-8). docs/outcome-engine.md, "The launch speed
delta"; the study setting ``delta`` changes it (with u_stop = delta, u_floor = delta / 100)."""
U_STOP = 1e-5
"""Slip speed [m/s] at or below which a slipping ball may return to rolling (= delta)."""
PHI_TOL = 1e-2
"""Largest angle [rad] between the slip direction and a limit direction for the return."""
U_FLOOR = 1e-7
"""Slip speed [m/s] at or below which the return is taken whatever the slip angle, if a limit
direction attracts (delta / 100): no slipping phase can creep towards u = 0 forever."""
DT_MAX = 1e-4
"""Longest extrapolated time u / (-u_dot*) [s] of a return: a barely attracting direction is
not trusted to carry the slip to 0 over a longer time."""

SW_DELTA = 0
SW_U_STOP = 1
SW_PHI_TOL = 2
SW_U_FLOOR = 3
SW_DT_MAX = 4
N_SW = 5


def default_tolerances(**changes) -> np.ndarray:
    """The switching-tolerance vector, defaults overridden by keyword (delta, u_stop, phi_tol, u_floor, dt_max)."""
    values = {"delta": DELTA, "u_stop": U_STOP, "phi_tol": PHI_TOL, "u_floor": U_FLOOR, "dt_max": DT_MAX}
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
    out[SW_DT_MAX] = values["dt_max"]
    return out


@engine_kernel(takes_functions=True)
def enter_slipping(y, p, switch_tol, load_fn=None):
    """Rolling layout (beta, w1, w2, w3, alpha) -> slipping layout with u = delta e(phi1), in place.

    The slip is launched by the tangential contact impulse J = j m delta e(phi1) / (1 + j) that
    creates it: v_G changes by J/m and omega by (r_GC x J)/(j m r^2) with r_GC = -r n2, i.e.
    omega1 by -delta sin(phi1) / ((1+j) r) and omega3 by +delta cos(phi1) / ((1+j) r). An
    impulse at a contact point at rest does no work to first order (J . v_C = 0), so the switch
    changes the energy only by (1/2) j m delta^2 / (1 + j), not by O(delta) as setting u at
    fixed omega would; that is what lets delta be large enough for cheap steps. ``load_fn``: the
    scene's external load (``solver.physics.loads.at``), None if it has none.
    """
    load = loads.at(load_fn, y[0], y[1], y[2], y[3], 0.0, 0.0, p)
    phi1 = slipping.limit_direction(y[0], y[1], y[2], y[3], p, load)
    delta = switch_tol[SW_DELTA]
    c = np.cos(phi1)
    s = np.sin(phi1)
    spin = delta / ((1.0 + p[P_J]) * p[P_R_BALL])
    y[6] = y[4]  # alpha moves to the end of the slipping layout
    y[1] -= spin * s
    y[3] += spin * c
    y[4] = delta * c
    y[5] = delta * s


@engine_kernel
def _wrap(angle):
    """angle wrapped to [-pi, pi)."""
    return (angle + np.pi) % (2.0 * np.pi) - np.pi


@engine_kernel
def _rate_phi1(y, p, load=None):
    """u_dot*(x, phi1) = |B| - C (79) [m/s^2], computed as -(1+j)/(j m) times the friction margin (39).

    The two are equal (paper Sect. 5.2.1: the repelling/attracting boundary of phi1 is the slip
    condition); using the margin makes the return test and the slip test one and the same
    function, so rounding (large when mu F2 and |F_t| nearly cancel, e.g. mu = 1e8 at
    separation) cannot make them disagree and chatter.
    """
    margin = rolling.friction_margin(y[0], y[1], y[2], y[3], p, load)
    return -(1.0 + p[P_J]) / (p[P_J] * p[P_M]) * margin


@engine_kernel(takes_functions=True)
def stop_slip_rate(y, p, switch_tol, load_fn=None):
    """u_dot* (79) [m/s^2] along the limit direction the slip returns by, or 0.0 if no return now.

    A negative value means: the slip reaches 0 within dt_max (see the module docstring).
    Returns (rate, along_phi1).
    """
    u1 = y[4]
    u3 = y[5]
    u = np.hypot(u1, u3)
    if u > switch_tol[SW_U_STOP]:
        return 0.0, False
    phi = np.arctan2(u3, u1)
    load = loads.at(load_fn, y[0], y[1], y[2], y[3], 0.0, 0.0, p)  # the directional limits: at u = 0
    phi1 = slipping.limit_direction(y[0], y[1], y[2], y[3], p, load)
    d1 = abs(_wrap(phi - phi1))
    d2 = abs(_wrap(phi - phi1 - np.pi))
    along1 = d1 <= d2
    rate1 = _rate_phi1(y, p, load)
    rate2 = slipping.radial_slip_rate(y[0], y[1], y[2], y[3], phi1 + np.pi, p, load)
    rate = rate1 if along1 else rate2
    fast = -rate * switch_tol[SW_DT_MAX] >= u
    if min(d1, d2) <= switch_tol[SW_PHI_TOL] and rate < 0.0 and fast:
        return rate, along1
    if u <= switch_tol[SW_U_FLOOR]:
        rate_far = rate2 if along1 else rate1
        if rate_far < rate:
            rate = rate_far
            along1 = not along1
        if rate < 0.0 and -rate * switch_tol[SW_DT_MAX] >= u:
            return rate, along1
    return 0.0, False


@engine_kernel(takes_functions=True)
def try_return(y, p, switch_tol, t_left, out, load_fn=None):
    """The slipping -> rolling map, if the return rule allows it now.

    On success writes the rolling state (beta, w1, w2, w3, alpha) into ``out`` and returns the
    time advanced (>= 0) [s]; returns -1.0 when slipping goes on. ``load_fn``: the scene's external
    load (``solver.physics.loads.at``), None if it has none.
    """
    rate, along1 = stop_slip_rate(y, p, switch_tol, load_fn)
    if not rate < 0.0:
        return -1.0
    for i in range(7):
        out[i] = y[i]
    dt = leave_slipping(out, p, rate, t_left, loads.at(load_fn, y[0], y[1], y[2], y[3], y[4], y[5], p))
    load = loads.at(load_fn, out[0], out[1], out[2], out[3], 0.0, 0.0, p)
    if along1 and not rolling.friction_margin(out[0], out[1], out[2], out[3], p, load) > 0.0:
        return -1.0
    return dt


@engine_kernel
def leave_slipping(y, p, rate, t_left, load=None):
    """Slipping layout -> rolling layout, in place, after the extrapolated time u / (-rate).

    The time is capped at t_left; the state moves by one Euler step of the slipping equations (with
    the external ``load`` at that state, if any). Returns the time advanced [s].
    """
    u1 = y[4]
    u3 = y[5]
    dt = min(np.hypot(u1, u3) / (-rate), t_left)
    b, d1, d2, d3, _, _ = slipping.slipping_rhs(y[0], y[1], y[2], y[3], u1, u3, p, load)
    alpha_dot = kinematics.alpha_rate(y[0], y[3], u1, p)
    alpha = y[6] + dt * alpha_dot
    y[0] += dt * b
    y[1] += dt * d1
    y[2] += dt * d2
    y[3] += dt * d3
    y[4] = alpha
    y[5] = 0.0
    y[6] = 0.0
    return dt
