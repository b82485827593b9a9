"""Rolling dynamics of the ball on the rim: (33)-(36) with the dissipation of (83).

State x = (beta, omega1, omega2, omega3): beta [rad], angular velocities [1/s] in the
contact basis (n1, n2, n3). The contact moment of docs/outcome-studies.md#scenes,

    M_C = -((1+j) m r^2 k_r omega1,  j m r^2 k_d omega2,  (1+j) m r^2 k_r omega3),

gives exactly the extra terms -k_r omega1, -k_d omega2, -k_r omega3 of (83) under the rolling
constraint, and the extra friction terms +m r k_r omega3 in F1 and -m r k_r omega1 in F3
(from Newton's law (24) with the rolling accelerations).

Every function takes scalars (compiled, for the integrator) or, through
``solver._jit.vectorised``, broadcasting numpy arrays, plus the flat vector ``p``.
"""

from __future__ import annotations

import numpy as np

from rimroll.solver._jit import physics_kernel
from rimroll.solver.physics import kinematics, loads
from rimroll.solver.physics.constants import constants
from rimroll.solver.physics.params import P_MU


@physics_kernel
def rolling_rhs(beta, omega1, omega2, omega3, p, load=None):
    """Right-hand side of the rolling equations (33)-(36) with dissipation (83), and the rates an
    external ``load`` adds (``solver.physics.loads``; None: none, and none of its code is compiled).

    Returns (beta_dot [rad/s], omega1_dot, omega2_dot, omega3_dot [1/s^2]).
    """
    r, R, rho, m, j, g, mu, k_r, k_d = constants(p)
    s = np.sin(beta)
    c = np.cos(beta)
    D = R - rho * c
    beta_dot = kinematics.beta_rate(omega1, 0.0, p)
    omega1_dot = (
        ((1.0 + j) * r * omega3 * omega3 * s - j * r * omega2 * omega3 * c) / ((1.0 + j) * D)
        - g * c / (r * (1.0 + j))
        - k_r * omega1
    )
    omega2_dot = r * R * omega1 * omega3 / (rho * D) - k_d * omega2
    omega3_dot = -r * omega1 * omega3 * s / D - j * r * omega1 * omega2 / (rho * (1.0 + j)) - k_r * omega3
    if load is not None:
        e1, e2, e3 = loads.rolling_rates(load, p)
        omega1_dot += e1
        omega2_dot += e2
        omega3_dot += e3
    return beta_dot, omega1_dot, omega2_dot, omega3_dot


@physics_kernel
def normal_force(beta, omega1, omega3, p, load=None):
    """Normal contact force F2 of a rolling ball (31) [N], less the normal component of an external
    ``load``'s force; the ball separates where F2 < 0."""
    r, R, rho, m, j, g, mu, k_r, k_d = constants(p)
    c = np.cos(beta)
    F2 = (m * r * r * omega3 * omega3 * c / (R - rho * c) - m * r * r * omega1 * omega1 / rho
          + m * g * np.sin(beta))
    if load is not None:
        F2 -= load[4]
    return F2


@physics_kernel
def normal_force_rate(beta, omega1, omega3, beta_dot, omega1_dot, omega3_dot, p):
    """Time derivative of the rolling normal force (31) along the rates given [N/s] (an external load's
    normal force is taken as constant over a step: the event locator then checks the dip on the
    dense output, ``solver.engine.events``)."""
    r, R, rho, m, j, g, mu, k_r, k_d = constants(p)
    s = np.sin(beta)
    c = np.cos(beta)
    D = R - rho * c
    mr2 = m * r * r
    d_beta = -mr2 * omega3 * omega3 * s * R / (D * D) + m * g * c
    return d_beta * beta_dot - 2.0 * mr2 * omega1 / rho * omega1_dot + 2.0 * mr2 * omega3 * c / D * omega3_dot


@physics_kernel
def contact_forces(beta, omega1, omega2, omega3, p, load=None):
    """Contact force (F1, F2, F3) [N] of a rolling ball in the n-basis: (30)-(32) plus dissipation,
    plus what an external ``load`` adds (``solver.physics.loads.contact_forces``).

    F1, F3 are the friction components, F2 the normal force.
    """
    r, R, rho, m, j, g, mu, k_r, k_d = constants(p)
    c = np.cos(beta)
    D = R - rho * c
    F1 = j * m * r * r * omega1 * omega2 / (rho * (1.0 + j)) + m * r * k_r * omega3
    F2 = normal_force(beta, omega1, omega3, p)
    F3 = (
        j * m * g * c / (1.0 + j)
        - j * m * r * r * omega2 * omega3 * c / ((1.0 + j) * D)
        - m * r * k_r * omega1
    )
    if load is not None:
        d1, d2, d3 = loads.contact_forces(load, p)
        F1 += d1
        F2 += d2
        F3 += d3
    return F1, F2, F3


@physics_kernel
def friction_margin(beta, omega1, omega2, omega3, p, load=None):
    """Margin of the friction cone (39), mu F2 - sqrt(F1^2 + F3^2) [N]; rolling is valid where >= 0.

    Meaningful for finite mu only (with mu = inf the cone is never left). ``load``: an external load.
    """
    F1, F2, F3 = contact_forces(beta, omega1, omega2, omega3, p, load)
    return p[P_MU] * F2 - np.sqrt(F1 * F1 + F3 * F3)


@physics_kernel
def contact_forces_rate(beta, omega1, omega2, omega3, beta_dot, omega1_dot, omega2_dot, omega3_dot, p):
    """Time derivative of the contact force (F1, F2, F3) of a rolling ball (``contact_forces``,
    without an external load) along the rates given [N/s]."""
    r, R, rho, m, j, g, mu, k_r, k_d = constants(p)
    s = np.sin(beta)
    c = np.cos(beta)
    D = R - rho * c
    k = j * m * r * r / (1.0 + j)
    dF1 = k / rho * (omega1_dot * omega2 + omega1 * omega2_dot) + m * r * k_r * omega3_dot
    dF2 = normal_force_rate(beta, omega1, omega3, beta_dot, omega1_dot, omega3_dot, p)
    dF3 = (-j * m * g * s * beta_dot / (1.0 + j)
           - k * ((omega2_dot * omega3 + omega2 * omega3_dot) * c / D - omega2 * omega3 * s * R * beta_dot / (D * D))
           - m * r * k_r * omega1_dot)
    return dF1, dF2, dF3


@physics_kernel
def friction_margin_rate(beta, omega1, omega2, omega3, beta_dot, omega1_dot, omega2_dot, omega3_dot, p):
    """Time derivative of the friction margin (39), mu dF2/dt - d|F_t|/dt [N/s], along the rates given
    (no external load). It lets the event locator bound the margin between step ends as it bounds
    F2 (``solver.engine.events``), so a slip onset inside a step is found, not sampled."""
    F1, F2, F3 = contact_forces(beta, omega1, omega2, omega3, p)
    dF1, dF2, dF3 = contact_forces_rate(beta, omega1, omega2, omega3, beta_dot, omega1_dot, omega2_dot, omega3_dot,
                                        p)
    ft = np.sqrt(F1 * F1 + F3 * F3)
    return p[P_MU] * dF2 - (F1 * dF1 + F3 * dF3) / ft


@physics_kernel
def energy(beta, omega1, omega2, omega3, p):
    """Total mechanical energy of the rolling ball (60) [J], with potential m g rho sin(beta).

    (60) as printed has m g r sin(beta); the centre's height is rho sin(beta) (12), and that is
    the potential the rolling equations conserve (docs/outcome-studies.md, end of "Rules").
    """
    r, R, rho, m, j, g, mu, k_r, k_d = constants(p)
    return (
        0.5 * m * j * r * r * omega2 * omega2
        + 0.5 * m * (1.0 + j) * r * r * (omega1 * omega1 + omega3 * omega3)
        + m * g * rho * np.sin(beta)
    )


@physics_kernel
def dissipated_power(omega1, omega2, omega3, p):
    """Power of the contact moment, M_C . omega [W] (<= 0): the rate dE/dt while rolling."""
    r, R, rho, m, j, g, mu, k_r, k_d = constants(p)
    return -m * r * r * ((1.0 + j) * k_r * (omega1 * omega1 + omega3 * omega3) + j * k_d * omega2 * omega2)
