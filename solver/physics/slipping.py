"""Slipping dynamics (41)-(42) and the nonsmooth limits at the rolling set (75)-(81).

State y = (beta, omega1, omega2, omega3, u1, u3): beta [rad], angular velocities [1/s],
slip velocities of the contact point u1, u3 [m/s].

Everything derives from one Newton-Euler model, (24)-(25) in the rotating n-basis with the
contact moment M_C of docs/outcome-studies.md#scenes (see ``solver.rolling``):

    omega_dot = a(y) + (-F3, 0, F1) / (j m r)
    u_dot     = b(y) + (1 + j) / (j m) * (F1, F3)

where (F1, F3) is the friction force. Coulomb friction (29) gives the slipping equations; the
friction that keeps u_dot = 0 at u = 0 gives the rolling equations (33)-(35)/(83) and the
rolling forces (30), (32); and b(x) at u = 0 is the directional-limit vector (B1, B3) of (76).
So the two phases agree at every switch by construction.
"""

from __future__ import annotations

import numpy as np

from rimroll.solver._jit import physics_kernel
from rimroll.solver.physics import kinematics, loads
from rimroll.solver.physics.params import P_G, P_J, P_K_D, P_K_R, P_M, P_MU, P_R_BALL, P_R_RIM, P_RHO


@physics_kernel
def free_rates(beta, omega1, omega2, omega3, u1, u3, p, load=None):
    """Rates of the state without friction force, and the normal force.

    Returns (beta_dot, a1, a2, a3, b1, b3, F2): beta_dot [rad/s]; a = omega_dot without
    friction [1/s^2] (contact moment M_C included); b = u_dot without friction [m/s^2]; F2 the
    normal force (41) [N]; with an external ``load`` (``solver.physics.loads.free_rates``) added.
    """
    r = p[P_R_BALL]
    j = p[P_J]
    s = np.sin(beta)
    c = np.cos(beta)
    V1 = u1 - r * omega3  # tangential velocity of the centre, n1 [m/s]
    V3 = u3 + r * omega1  # velocity of the centre along n3 [m/s]
    alpha_dot, beta_dot = kinematics.angle_rates(beta, omega1, omega3, u1, u3, p)
    Om2 = alpha_dot * s  # n2, n3 components of the basis' angular velocity (11)
    Om3 = alpha_dot * c
    a1 = -(Om2 * omega3 - Om3 * omega2) - (1.0 + j) / j * p[P_K_R] * omega1
    a2 = -(Om3 * omega1 - beta_dot * omega3) - p[P_K_D] * omega2
    a3 = -(beta_dot * omega2 - Om2 * omega1) - (1.0 + j) / j * p[P_K_R] * omega3
    b1 = r * a3 - Om2 * V3
    b3 = -r * a1 - p[P_G] * c + Om2 * V1
    F2 = p[P_M] * (Om3 * V1 - beta_dot * V3 + p[P_G] * s)
    if load is not None:
        da1, da2, da3, db1, db3, dF2 = loads.free_rates(load, p)
        a1 += da1
        a2 += da2
        a3 += da3
        b1 += db1
        b3 += db3
        F2 += dF2
    return beta_dot, a1, a2, a3, b1, b3, F2


@physics_kernel
def newton_euler_rates(beta, omega1, omega2, omega3, u1, u3, F1, F3, p):
    """Rates of y under a given friction force (F1, F3) [N] at the contact point.

    Returns (beta_dot, omega1_dot, omega2_dot, omega3_dot, u1_dot, u3_dot).
    """
    beta_dot, a1, a2, a3, b1, b3, _ = free_rates(beta, omega1, omega2, omega3, u1, u3, p)
    jm = p[P_J] * p[P_M]
    jmr = jm * p[P_R_BALL]
    k = (1.0 + p[P_J]) / jm
    return beta_dot, a1 - F3 / jmr, a2, a3 + F1 / jmr, b1 + k * F1, b3 + k * F3


@physics_kernel
def slipping_rhs(beta, omega1, omega2, omega3, u1, u3, p, load=None):
    """Right-hand side of the slipping equations (42) with dissipation and an external ``load``, for u != 0.

    Coulomb friction (29): (F1, F3) = -mu F2 (u1, u3) / |u|. Returns the six rates
    (beta_dot, omega1_dot, omega2_dot, omega3_dot, u1_dot, u3_dot).
    """
    beta_dot, a1, a2, a3, b1, b3, F2 = free_rates(beta, omega1, omega2, omega3, u1, u3, p, load)
    speed = np.sqrt(u1 * u1 + u3 * u3)
    F1 = -p[P_MU] * F2 * u1 / speed
    F3 = -p[P_MU] * F2 * u3 / speed
    jm = p[P_J] * p[P_M]
    jmr = jm * p[P_R_BALL]
    k = (1.0 + p[P_J]) / jm
    return beta_dot, a1 - F3 / jmr, a2, a3 + F1 / jmr, b1 + k * F1, b3 + k * F3


@physics_kernel
def slipping_jacobian(beta, omega1, omega2, omega3, u1, u3, p, J):
    """Jacobian of the slipping equations (42) (no external load) into J[:7, :7].

    Rows: the rates of (beta, omega1, omega2, omega3, u1, u3) of ``slipping_rhs`` and alpha_dot
    of (19); columns: the derivatives by (beta [rad], omega1, omega2, omega3 [1/s], u1, u3 [m/s],
    alpha [rad]) (the last column is zero: nothing depends on alpha). Forward differentiation by
    hand: column k is the derivative along the unit vector e_k, each line the derivative of the
    line of the same name in ``free_rates`` and ``slipping_rhs``. Units: those of the rate
    over those of the variable. Its entries in u grow as 1/|u| (the slip angle relaxes at
    |B|/|u|), which is what makes (42) stiff for small slips: an implicit or linearly implicit
    (Rosenbrock) step of a slip phase solves with this matrix.
    """
    r = p[P_R_BALL]
    rho = p[P_RHO]
    j = p[P_J]
    m = p[P_M]
    g = p[P_G]
    mu = p[P_MU]
    kk = (1.0 + j) / j * p[P_K_R]
    kd = p[P_K_D]
    jmr = j * m * r
    kf = (1.0 + j) / (j * m)
    s = np.sin(beta)
    c = np.cos(beta)
    D = p[P_R_RIM] - rho * c
    V1 = u1 - r * omega3
    V3 = u3 + r * omega1
    ad = V1 / D  # alpha_dot
    bd = V3 / rho  # beta_dot
    Om2 = ad * s
    Om3 = ad * c
    F2 = m * (Om3 * V1 - bd * V3 + g * s)
    speed = np.sqrt(u1 * u1 + u3 * u3)
    e1 = u1 / speed
    e3 = u3 / speed
    for k in range(6):
        db = 1.0 if k == 0 else 0.0
        dw1 = 1.0 if k == 1 else 0.0
        dw2 = 1.0 if k == 2 else 0.0
        dw3 = 1.0 if k == 3 else 0.0
        du1 = 1.0 if k == 4 else 0.0
        du3 = 1.0 if k == 5 else 0.0
        dV1 = du1 - r * dw3
        dV3 = du3 + r * dw1
        dad = (dV1 - ad * rho * s * db) / D
        dbd = dV3 / rho
        dOm2 = dad * s + ad * c * db
        dOm3 = dad * c - ad * s * db
        da1 = -(dOm2 * omega3 + Om2 * dw3 - dOm3 * omega2 - Om3 * dw2) - kk * dw1
        da2 = -(dOm3 * omega1 + Om3 * dw1 - dbd * omega3 - bd * dw3) - kd * dw2
        da3 = -(dbd * omega2 + bd * dw2 - dOm2 * omega1 - Om2 * dw1) - kk * dw3
        db1 = r * da3 - dOm2 * V3 - Om2 * dV3
        db3 = -r * da1 + g * s * db + dOm2 * V1 + Om2 * dV1
        dF2 = m * (dOm3 * V1 + Om3 * dV1 - dbd * V3 - bd * dV3 + g * c * db)
        dspeed = e1 * du1 + e3 * du3
        de1 = (du1 - e1 * dspeed) / speed
        de3 = (du3 - e3 * dspeed) / speed
        dF1 = -mu * (dF2 * e1 + F2 * de1)
        dF3 = -mu * (dF2 * e3 + F2 * de3)
        J[0, k] = dbd
        J[1, k] = da1 - dF3 / jmr
        J[2, k] = da2
        J[3, k] = da3 + dF1 / jmr
        J[4, k] = db1 + kf * dF1
        J[5, k] = db3 + kf * dF3
        J[6, k] = dad
    for i in range(7):
        J[i, 6] = 0.0


@physics_kernel
def slipping_normal_force(beta, omega1, omega3, u1, u3, p, load=None):
    """Normal contact force of a slipping ball (41) [N], less the normal component of an external
    ``load``'s force."""
    r = p[P_R_BALL]
    rho = p[P_RHO]
    c = np.cos(beta)
    V1 = u1 - r * omega3
    V3 = u3 + r * omega1
    m = p[P_M]
    F2 = m * V1 * V1 * c / (p[P_R_RIM] - rho * c) - m * V3 * V3 / rho + m * p[P_G] * np.sin(beta)
    if load is not None:
        F2 -= load[4]
    return F2


@physics_kernel
def slipping_normal_force_rate(beta, omega1, omega3, u1, u3, beta_dot, omega1_dot, omega3_dot, u1_dot, u3_dot, p):
    """Time derivative of the slipping normal force (41) along the rates given [N/s]."""
    r = p[P_R_BALL]
    rho = p[P_RHO]
    R = p[P_R_RIM]
    s = np.sin(beta)
    c = np.cos(beta)
    D = R - rho * c
    V1 = u1 - r * omega3
    V3 = u3 + r * omega1
    m = p[P_M]
    d_beta = -V1 * V1 * s * R / (D * D) + p[P_G] * c
    return m * (d_beta * beta_dot + 2.0 * V1 * c / D * (u1_dot - r * omega3_dot)
                - 2.0 * V3 / rho * (u3_dot + r * omega1_dot))


@physics_kernel
def directional_limits(beta, omega1, omega2, omega3, p, load=None):
    """B1, B3 [m/s^2] and C [m/s^2] of (76) at a rolling state (dissipation and an external ``load``
    included).

    The directional limit of u_dot from the direction phi is (B1 - C cos phi, B3 - C sin phi) (75).
    """
    _, _, _, _, b1, b3, F2 = free_rates(beta, omega1, omega2, omega3, 0.0, 0.0, p, load)
    return b1, b3, p[P_MU] * (1.0 + p[P_J]) / (p[P_J] * p[P_M]) * F2


@physics_kernel
def limit_direction(beta, omega1, omega2, omega3, p, load=None):
    """The limit direction phi1 = atan2(B3, B1) of (81) [rad]; phi2 = phi1 + pi."""
    b1, b3, _ = directional_limits(beta, omega1, omega2, omega3, p, load)
    return np.arctan2(b3, b1)


@physics_kernel
def radial_slip_rate(beta, omega1, omega2, omega3, phi, p, load=None):
    """Directional limit of the slip speed's rate, u_dot*(x, phi) of (79) [m/s^2].

    Positive: the direction phi is repelling (slip grows); negative: attracting.
    """
    b1, b3, C = directional_limits(beta, omega1, omega2, omega3, p, load)
    return b1 * np.cos(phi) + b3 * np.sin(phi) - C


@physics_kernel
def energy(beta, omega1, omega2, omega3, u1, u3, p):
    """Total mechanical energy of a slipping ball [J]: (1/2) m |v_G|^2 + (1/2) j m r^2 |omega|^2 + m g rho sin(beta).

    Equals the rolling energy (60) (with rho) at u = 0.
    """
    r = p[P_R_BALL]
    m = p[P_M]
    V1 = u1 - r * omega3
    V3 = u3 + r * omega1
    return (
        0.5 * m * (V1 * V1 + V3 * V3)
        + 0.5 * p[P_J] * m * r * r * (omega1 * omega1 + omega2 * omega2 + omega3 * omega3)
        + m * p[P_G] * p[P_RHO] * np.sin(beta)
    )
