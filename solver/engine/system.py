"""The integrated systems of the outcome engine: state layouts, right-hand sides, event tables.

Two phases, each a system the generic integrator (``solver.engine.stepper``, ``solver.engine.events``) is
handed as functions:

* rolling:  y = (beta, omega1, omega2, omega3, alpha), n = 5, rates (33)-(36)/(83);
* slipping: y = (beta, omega1, omega2, omega3, u1, u3, alpha), n = 7, rates (42).

alpha, the cyclic angle (19), is stored last and only integrated to report revolutions; it never
feeds back and is left out of the error norm. Its rate, like every rate of the contact angles,
comes from ``solver.kinematics`` (19)-(20).

Per phase, ``*_rhs(y, model, K, s)`` writes the rates of y into row s of the 2-D array K (the one
right-hand side of the phase; ``model``: a :class:`Model`, the parameters and the scene's external
load), and ``*_events(y, f, model, switch_tol, g, gr)`` writes the event values
into g and their time derivatives (along the rates f) into gr; a derivative that is not available
cheaply is NaN. ``switch_tol`` is the switching-tolerance vector of ``solver.physics.switching`` in
scenes that slip and None in rolling-only ones: numba prunes a branch on ``switch_tol is None`` before it
compiles, so a rolling-only kernel holds no friction cone and no slipping code at all.

The event tables (declared data, read by the engine and the locator):

=====  ==================================  =====  =========  ==========================
index  rolling                             dir.   min        action
=====  ==================================  =====  =========  ==========================
0      F2 (31)                             down   tracked    FALL (free flight)
1      friction margin (39) (finite mu)    down   tracked    SLIP (enter slipping)
2      omega1 (conservative scenes)        both   -          OMEGA1 (count a crossing)
=====  ==================================  =====  =========  ==========================

=====  ==================================  =====  =========  ==========================
index  slipping                            dir.   min        action
=====  ==================================  =====  =========  ==========================
0      F2 (41)                             down   tracked    FALL (free flight)
1      |u| - u_stop                        down   -          RETURN (try to roll again)
2      (unused)                            -      -          NONE
=====  ==================================  =====  =========  ==========================

"dir." is the crossing direction that fires (-1 down, +1 up, 0 both); "min" marks the events
whose minimum over each step the locator tracks (``solver.engine.events``: a dip of F2 below zero
inside a step is a fall even if F2 is positive at both step ends, and a dip of the friction margin
a slip onset; both have analytic rates, so the gate bounds them between the step ends).
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np

from rimroll.solver._compile import engine_kernel
from rimroll.solver.physics import kinematics, loads, rolling, slipping
from rimroll.solver.physics.switching import SW_DELTA, SW_U_STOP

N_ROLLING = 5  # beta, omega1, omega2, omega3, alpha
N_SLIPPING = 7  # beta, omega1, omega2, omega3, u1, u3, alpha
N_MAX = 7
I_U1 = 4  # slipping layout
I_U3 = 5

# Event indices and actions.
N_EVENTS = 3
EV_FALL = 0
EV_SWITCH = 1  # slip onset while rolling, |u| = u_stop while slipping
EV_OMEGA1 = 2
ACT_NONE, ACT_FALL, ACT_SLIP, ACT_RETURN, ACT_OMEGA1 = 0, 1, 2, 3, 4

ROLLING_DIRECTION = np.array([-1, -1, 0], dtype=np.int64)
ROLLING_TRACK_MIN = np.array([True, True, False])
ROLLING_ACTION = np.array([ACT_FALL, ACT_SLIP, ACT_OMEGA1], dtype=np.int64)
SLIPPING_DIRECTION = np.array([-1, -1, 0], dtype=np.int64)
SLIPPING_TRACK_MIN = np.array([True, False, False])
SLIPPING_ACTION = np.array([ACT_FALL, ACT_RETURN, ACT_NONE], dtype=np.int64)


U_ATOL_FRACTION = 1e-3
"""Absolute tolerance of the slip velocity u1, u3, as a fraction of the slip launch speed delta
[m/s]: the error control must resolve u on the scale on which the return rule reads it (u_stop
= delta, the slip angle to 1e-2 rad). With the user's atol instead (1e-6 m/s at rtol 1e-4), u is
known to 10% of delta, its angle is noise, the return rule is not met and the slip goes on at
the stability limit of the stiff slipping equations: rtol 1e-4 cost 6x rtol 1e-6."""


class Model(NamedTuple):
    """What the equations of a scene need besides the state: the flat parameter vector ``p``
    (``Params.as_array``); ``load_fn``, the function of the state giving the external load of the
    scene's terms (``solver.physics.loads``), or None for a scene without terms (its equations then
    compile without any load); and ``slipping``, the phase the hybrid system functions run
    (:func:`hybrid_rhs`, :func:`hybrid_events`)."""

    p: np.ndarray
    load_fn: object
    slipping: bool


@engine_kernel(inline=True)
def rolling_load(model, y):
    """The load of the scene's terms at the rolling state y (None in a scene without terms)."""
    return loads.at(model.load_fn, y[0], y[1], y[2], y[3], 0.0, 0.0, model.p)


@engine_kernel(inline=True)
def slipping_load(model, y):
    """The load of the scene's terms at the slipping state y (None in a scene without terms)."""
    return loads.at(model.load_fn, y[0], y[1], y[2], y[3], y[I_U1], y[I_U3], model.p)


class Phase(NamedTuple):
    """One phase of a scene as the engine runs it: ``n`` live components (alpha last, outside the
    error norm), its event table (``direction``, ``track_min``, ``action``; ``active``: which of
    the events the scene has) and the absolute tolerance of each component (``atol``)."""

    n: int
    direction: np.ndarray
    track_min: np.ndarray
    action: np.ndarray
    active: np.ndarray
    atol: np.ndarray


@engine_kernel(inline=True)
def phases(switch_tol, conservative, atol, active, atol_roll, atol_slip):
    """The rolling and slipping :class:`Phase` of the scene (switch_tol: the switching tolerances of a scene
    that slips, None if it only rolls): fills the bool array ``active`` (2, N_EVENTS) and the
    tolerance vectors ``atol_roll``, ``atol_slip``."""
    rolling_active(switch_tol is not None, conservative, active[0])
    slipping_active(switch_tol is not None, conservative, active[1])
    rolling_atol(atol, atol_roll)
    if switch_tol is not None:
        slipping_atol(atol, switch_tol, atol_slip)
    return (Phase(N_ROLLING, ROLLING_DIRECTION, ROLLING_TRACK_MIN, ROLLING_ACTION, active[0], atol_roll),
            Phase(N_SLIPPING, SLIPPING_DIRECTION, SLIPPING_TRACK_MIN, SLIPPING_ACTION, active[1], atol_slip))


@engine_kernel
def rolling_atol(atol, out):
    """Absolute tolerances of the rolling components into ``out``: atol for each [their units]."""
    for i in range(N_ROLLING):
        out[i] = atol


@engine_kernel
def slipping_atol(atol, switch_tol, out):
    """Absolute tolerances of the slipping components into ``out``: atol, and for u1, u3
    min(atol, U_ATOL_FRACTION * delta) [m/s]."""
    for i in range(N_SLIPPING):
        out[i] = atol
    u_atol = min(atol, U_ATOL_FRACTION * switch_tol[SW_DELTA])
    out[I_U1] = u_atol
    out[I_U3] = u_atol


@engine_kernel
def rolling_active(hybrid, conservative, out):
    """Active rolling events of a scene into the bool array ``out`` (N_EVENTS)."""
    out[EV_FALL] = True
    out[EV_SWITCH] = hybrid
    out[EV_OMEGA1] = conservative


@engine_kernel
def slipping_active(hybrid, conservative, out):
    """Active slipping events of a scene into the bool array ``out`` (N_EVENTS)."""
    out[EV_FALL] = True
    out[EV_SWITCH] = True
    out[EV_OMEGA1] = False


@engine_kernel(inline=True)
def rolling_rhs(y, model, K, s):
    """Rates of the rolling state y, (33)-(36)/(83) with the scene's load and alpha_dot (19), into
    row s of K."""
    beta = y[0]
    w1 = y[1]
    w3 = y[3]
    p = model.p
    b, d1, d2, d3 = rolling.rolling_rhs(beta, w1, y[2], w3, p, rolling_load(model, y))
    alpha_dot = kinematics.alpha_rate(beta, w3, 0.0, p)
    K[s, 0] = b
    K[s, 1] = d1
    K[s, 2] = d2
    K[s, 3] = d3
    K[s, 4] = alpha_dot


@engine_kernel(inline=True)
def slipping_rhs(y, model, K, s):
    """Rates of the slipping state y, (42) with the scene's load and alpha_dot (19), into row s of K."""
    beta = y[0]
    w1 = y[1]
    w3 = y[3]
    u1 = y[I_U1]
    u3 = y[I_U3]
    p = model.p
    b, d1, d2, d3, du1, du3 = slipping.slipping_rhs(beta, w1, y[2], w3, u1, u3, p, slipping_load(model, y))
    alpha_dot = kinematics.alpha_rate(beta, w3, u1, p)
    K[s, 0] = b
    K[s, 1] = d1
    K[s, 2] = d2
    K[s, 3] = d3
    K[s, 4] = du1
    K[s, 5] = du3
    K[s, 6] = alpha_dot


@engine_kernel(inline=True)
def rolling_events(y, f, model, switch_tol, g, gr):
    """Rolling event values into g, their time derivatives along the rates f into gr (see the table);
    the friction margin only where the ball can slip (switch_tol not None). With an external load the
    derivatives of what it adds are central differences along f (:func:`_rolling_event_rates`)."""
    beta = y[0]
    w1 = y[1]
    w3 = y[3]
    p = model.p
    load = rolling_load(model, y)
    g[EV_FALL] = rolling.normal_force(beta, w1, w3, p, load)
    gr[EV_FALL] = rolling.normal_force_rate(beta, w1, w3, f[0], f[1], f[3], p)
    if switch_tol is not None:
        g[EV_SWITCH] = rolling.friction_margin(beta, w1, y[2], w3, p, load)
        gr[EV_SWITCH] = rolling.friction_margin_rate(beta, w1, y[2], w3, f[0], f[1], f[2], f[3], p)
    else:
        g[EV_SWITCH] = 1.0
        gr[EV_SWITCH] = 0.0
    if load is not None:
        _rolling_event_rates(y, f, model, switch_tol, gr)
    g[EV_OMEGA1] = w1
    gr[EV_OMEGA1] = f[1]


FD_STEP = 1e-6
"""Relative size [s, times the rates' largest component] of the central difference that gives the
rolling events' rates in a scene with an external load (whose own rates the loads do not give)."""


@engine_kernel(inline=True)
def _rolling_event_rates(y, f, model, switch_tol, gr):
    """Adds to the analytic rates of F2 and of the friction margin (of the equations without the
    load, along the rates f) the rates of what the load adds to them, by central differences along f.
    Only the load's part is differenced: it is exactly zero for a load of zero strength, which then
    gives the rates of the scene without it bit for bit."""
    p = model.p
    scale = max(max(abs(f[0]), abs(f[1])), max(abs(f[2]), abs(f[3])))
    dt = FD_STEP / max(scale, 1.0)
    b0, w10, w20, w30 = y[0] + dt * f[0], y[1] + dt * f[1], y[2] + dt * f[2], y[3] + dt * f[3]
    b1, w11, w21, w31 = y[0] - dt * f[0], y[1] - dt * f[1], y[2] - dt * f[2], y[3] - dt * f[3]
    load0 = loads.at(model.load_fn, b0, w10, w20, w30, 0.0, 0.0, p)
    load1 = loads.at(model.load_fn, b1, w11, w21, w31, 0.0, 0.0, p)
    gr[EV_FALL] += ((rolling.normal_force(b0, w10, w30, p, load0) - rolling.normal_force(b0, w10, w30, p))
                    - (rolling.normal_force(b1, w11, w31, p, load1) - rolling.normal_force(b1, w11, w31, p))
                    ) / (2.0 * dt)
    if switch_tol is not None:
        gr[EV_SWITCH] += ((rolling.friction_margin(b0, w10, w20, w30, p, load0)
                           - rolling.friction_margin(b0, w10, w20, w30, p))
                          - (rolling.friction_margin(b1, w11, w21, w31, p, load1)
                             - rolling.friction_margin(b1, w11, w21, w31, p))) / (2.0 * dt)


@engine_kernel(inline=True)
def slipping_events(y, f, model, switch_tol, g, gr):
    """Slipping event values into g, their time derivatives along the rates f into gr (see the table)."""
    u1 = y[I_U1]
    u3 = y[I_U3]
    p = model.p
    g[EV_FALL] = slipping.slipping_normal_force(y[0], y[1], y[3], u1, u3, p, slipping_load(model, y))
    gr[EV_FALL] = slipping.slipping_normal_force_rate(y[0], y[1], y[3], u1, u3, f[0], f[1], f[3], f[I_U1],
                                                      f[I_U3], p)
    u = np.hypot(u1, u3)
    g[EV_SWITCH] = u - switch_tol[SW_U_STOP]
    gr[EV_SWITCH] = (u1 * f[I_U1] + u3 * f[I_U3]) / u
    g[EV_OMEGA1] = 0.0
    gr[EV_OMEGA1] = 0.0


@engine_kernel(inline=True)
def load_rates(y, model, R, row):
    """What the scene's load adds to the slipping rates at y, into R[row, :N_SLIPPING - 1]: (42) with
    the load minus (42) without it (exact zeros for a load of zero strength)."""
    beta = y[0]
    w1 = y[1]
    w3 = y[3]
    u1 = y[I_U1]
    u3 = y[I_U3]
    p = model.p
    with_load = slipping.slipping_rhs(beta, w1, y[2], w3, u1, u3, p, slipping_load(model, y))
    without = slipping.slipping_rhs(beta, w1, y[2], w3, u1, u3, p, None)
    for i in range(N_SLIPPING - 1):
        R[row, i] = with_load[i] - without[i]


@engine_kernel(inline=True)
def slipping_jacobian(y, model, J, R, row, tmp):
    """Jacobian of the slipping rates of :func:`slipping_rhs` at y into J[:7, :7]: the analytic one
    of (42) (``slipping.slipping_jacobian``), plus, in a scene with terms, forward differences of
    what the load adds (:func:`load_rates`; step sqrt(eps) relative, at least 1e-4 of a unit for
    angles and rates, 1e-4 of the slip speed for the slip velocity). R[row], R[row + 1] and tmp are
    scratch."""
    slipping.slipping_jacobian(y[0], y[1], y[2], y[3], y[I_U1], y[I_U3], model.p, J)
    if model.load_fn is not None:
        load_rates(y, model, R, row + 1)
        for k in range(N_MAX):
            tmp[k] = y[k]
        u = max(abs(y[I_U1]), abs(y[I_U3]), 1e-8)
        for k in range(N_MAX - 1):
            dk = 1.5e-8 * max(abs(y[k]), 1e-4 if k < I_U1 else 1e-4 * u)
            tmp[k] = y[k] + dk
            load_rates(tmp, model, R, row)
            for i in range(N_MAX - 1):
                J[i, k] += (R[row, i] - R[row + 1, i]) / dk
            tmp[k] = y[k]


@engine_kernel(inline=True)
def hybrid_rhs(y, model, K, s):
    """Rates of the phase ``model.slipping`` says: one step loop serves both phases of a scene that
    slips (compiled once, not once per phase)."""
    if model.slipping:
        slipping_rhs(y, model, K, s)
    else:
        rolling_rhs(y, model, K, s)


@engine_kernel(inline=True)
def hybrid_events(y, f, model, switch_tol, g, gr):
    """Event values of the phase ``model.slipping`` says (see :func:`hybrid_rhs`)."""
    if model.slipping:
        slipping_events(y, f, model, switch_tol, g, gr)
    else:
        rolling_events(y, f, model, switch_tol, g, gr)


@engine_kernel
def rolling_energy(y, p):
    """Mechanical energy of the rolling state [J]: (60) with m g rho sin(beta)."""
    return rolling.energy(y[0], y[1], y[2], y[3], p)


@engine_kernel
def slipping_energy(y, p):
    """Mechanical energy of the slipping state [J] (equals (60) at u = 0)."""
    return slipping.energy(y[0], y[1], y[2], y[3], y[I_U1], y[I_U3], p)
