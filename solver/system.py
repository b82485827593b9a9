"""The integrated systems: state layouts, right-hand sides and event functions of each phase.

Two phases, selected by an integer so that one compiled stepper serves both:

* ``ROLLING``:  y = (beta, omega1, omega2, omega3, alpha), n = 5, rates (33)-(36)/(83);
* ``SLIPPING``: y = (beta, omega1, omega2, omega3, u1, u3, alpha), n = 7, rates (42).

alpha, the cyclic angle (19), is stored last and only integrated to report revolutions; it
never feeds back and is left out of the error norm.

Events are data (one table per phase): ``event_values`` fills g[0..N_EVENTS-1], and the arrays
``ROLLING_DIRECTION`` / ``SLIPPING_DIRECTION`` give the crossing direction that counts (-1:
downward, +1: upward, 0: either). What each index means:

=====  ==========================================  ==========================================
index  ROLLING                                     SLIPPING
=====  ==========================================  ==========================================
0      F2 (31), down: the ball separates (FALL)    F2 (41), down: the ball separates (FALL)
1      friction margin (39), down: START_SLIP      |u| - u_stop (switching), down: NEAR_ROLL
2      omega1, either way: OMEGA1_ZERO             unused
=====  ==========================================  ==========================================

A third phase, ``OSCILLATOR``, is a test problem with a closed-form solution (the harmonic
oscillator x'' = -x and the quadrature q' = x; events x, v, x - 1/2) that lets the tests drive
the very same compiled stepper and event code.
"""

from __future__ import annotations

import numpy as np

from solver import rolling, slipping
from solver._compile import kernel
from solver.params import P_R_BALL, P_R_RIM, P_RHO
from solver.switching import SW_U_STOP

ROLLING = 0
SLIPPING = 1
OSCILLATOR = 2  # test problem for the integrator: y = (x, v, q), x' = v, v' = -x, q' = x (n = 3)

N_ROLLING = 5  # beta, omega1, omega2, omega3, alpha
N_SLIPPING = 7  # beta, omega1, omega2, omega3, u1, u3, alpha
N_MAX = 7
I_U1 = 4  # slipping layout
I_U3 = 5

N_EVENTS = 3
EV_FALL = 0
EV_SWITCH = 1  # START_SLIP while rolling, NEAR_ROLL while slipping
EV_OMEGA1 = 2
ROLLING_DIRECTION = np.array([-1, -1, 0], dtype=np.int64)
SLIPPING_DIRECTION = np.array([-1, -1, 0], dtype=np.int64)



@kernel
def rhs(phase, y, p, out):
    """Rates of the phase's state y into ``out`` (alpha_dot last)."""
    if phase == ROLLING:
        beta = y[0]
        w3 = y[3]
        b, d1, d2, d3 = rolling.rolling_rhs(beta, y[1], y[2], w3, p)
        out[0] = b
        out[1] = d1
        out[2] = d2
        out[3] = d3
        out[4] = -p[P_R_BALL] * w3 / (p[P_R_RIM] - p[P_RHO] * np.cos(beta))
    elif phase == SLIPPING:
        beta = y[0]
        w3 = y[3]
        u1 = y[I_U1]
        u3 = y[I_U3]
        b, d1, d2, d3, du1, du3 = slipping.slipping_rhs(beta, y[1], y[2], w3, u1, u3, p)
        out[0] = b
        out[1] = d1
        out[2] = d2
        out[3] = d3
        out[4] = du1
        out[5] = du3
        out[6] = (u1 - p[P_R_BALL] * w3) / (p[P_R_RIM] - p[P_RHO] * np.cos(beta))
    else:
        out[0] = y[1]
        out[1] = -y[0]
        out[2] = y[0]


@kernel(inline=True)
def rhs_row(phase, y, p, K, s):
    """As :func:`rhs`, into row s of the 2-D array K (no array view is made: the hot path)."""
    if phase == ROLLING:
        beta = y[0]
        w3 = y[3]
        b, d1, d2, d3 = rolling.rolling_rhs(beta, y[1], y[2], w3, p)
        K[s, 0] = b
        K[s, 1] = d1
        K[s, 2] = d2
        K[s, 3] = d3
        K[s, 4] = -p[P_R_BALL] * w3 / (p[P_R_RIM] - p[P_RHO] * np.cos(beta))
    elif phase == SLIPPING:
        beta = y[0]
        w3 = y[3]
        u1 = y[I_U1]
        u3 = y[I_U3]
        b, d1, d2, d3, du1, du3 = slipping.slipping_rhs(beta, y[1], y[2], w3, u1, u3, p)
        K[s, 0] = b
        K[s, 1] = d1
        K[s, 2] = d2
        K[s, 3] = d3
        K[s, 4] = du1
        K[s, 5] = du3
        K[s, 6] = (u1 - p[P_R_BALL] * w3) / (p[P_R_RIM] - p[P_RHO] * np.cos(beta))
    else:
        K[s, 0] = y[1]
        K[s, 1] = -y[0]
        K[s, 2] = y[0]


@kernel
def event_values(phase, hybrid, y, p, sw, g):
    """Event functions of the phase at state y into g (see the module table).

    ``sw`` is the switching-tolerance vector of ``solver.switching`` (u_stop = sw[SW_U_STOP]).
    """
    if phase == ROLLING:
        g[EV_FALL] = rolling.normal_force(y[0], y[1], y[3], p)
        if hybrid:
            g[EV_SWITCH] = rolling.friction_margin(y[0], y[1], y[2], y[3], p)
        else:
            g[EV_SWITCH] = 1.0
        g[EV_OMEGA1] = y[1]
    elif phase == SLIPPING:
        g[EV_FALL] = slipping.slipping_normal_force(y[0], y[1], y[3], y[I_U1], y[I_U3], p)
        g[EV_SWITCH] = np.hypot(y[I_U1], y[I_U3]) - sw[SW_U_STOP]
        g[EV_OMEGA1] = 0.0
    else:  # OSCILLATOR: x, v, and x - 0.5
        g[0] = y[0]
        g[1] = y[1]
        g[2] = y[0] - 0.5


@kernel
def event_rates(phase, hybrid, y, f, p, sw, gr):
    """Time derivatives of the event functions at state y with rates f = rhs(y), into gr.

    They feed the grazing gate of ``solver.events.may_cross`` (a cubic Hermite model of each
    event function over a step). A rate that is not available cheaply is NaN, which makes the
    gate always ask for the full scan (the friction margin (39) of a hybrid rolling phase).
    """
    if phase == ROLLING:
        gr[EV_FALL] = rolling.normal_force_rate(y[0], y[1], y[3], f[0], f[1], f[3], p)
        if hybrid:
            gr[EV_SWITCH] = np.nan
        else:
            gr[EV_SWITCH] = 0.0
        gr[EV_OMEGA1] = f[1]
    elif phase == SLIPPING:
        u1 = y[I_U1]
        u3 = y[I_U3]
        gr[EV_FALL] = slipping.slipping_normal_force_rate(y[0], y[1], y[3], u1, u3, f[0], f[1], f[3], f[I_U1],
                                                          f[I_U3], p)
        gr[EV_SWITCH] = (u1 * f[I_U1] + u3 * f[I_U3]) / np.hypot(u1, u3)
        gr[EV_OMEGA1] = 0.0
    else:  # OSCILLATOR
        gr[0] = f[0]
        gr[1] = f[1]
        gr[2] = f[0]


@kernel(inline=True)
def event_values_rates(phase, hybrid, y, f, p, sw, g, gr):
    """:func:`event_values` and :func:`event_rates` at once (one sin/cos of beta: the step end)."""
    if phase == ROLLING:
        beta = y[0]
        w1 = y[1]
        w3 = y[3]
        g[EV_FALL] = rolling.normal_force(beta, w1, w3, p)
        gr[EV_FALL] = rolling.normal_force_rate(beta, w1, w3, f[0], f[1], f[3], p)
        if hybrid:
            g[EV_SWITCH] = rolling.friction_margin(beta, w1, y[2], w3, p)
            gr[EV_SWITCH] = np.nan
        else:
            g[EV_SWITCH] = 1.0
            gr[EV_SWITCH] = 0.0
        g[EV_OMEGA1] = w1
        gr[EV_OMEGA1] = f[1]
    else:
        event_values(phase, hybrid, y, p, sw, g)
        event_rates(phase, hybrid, y, f, p, sw, gr)


@kernel
def state_energy(phase, y, p):
    """Mechanical energy of the state [J]: (60) with m g rho sin(beta), or its slipping form."""
    if phase == ROLLING:
        return rolling.energy(y[0], y[1], y[2], y[3], p)
    return slipping.energy(y[0], y[1], y[2], y[3], y[I_U1], y[I_U3], p)
