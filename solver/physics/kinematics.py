"""Kinematics of the ball on the rim: angle rates (19)-(20), centre position (12), velocity (13).

All functions take scalars (compiled) or broadcasting numpy arrays (``vectorised``), and a
flat parameter vector ``p`` from ``solver.Params.as_array``. Angles in rad, angular
velocities in 1/s, lengths in m, speeds in m/s.
"""

from __future__ import annotations

import numpy as np

from rimroll.solver._jit import physics_kernel
from rimroll.solver.physics.params import P_R_BALL, P_R_RIM, P_RHO


@physics_kernel
def alpha_rate(beta, omega3, u1, p):
    """Rate of the angle around the rim (19): alpha_dot = (u1 - r omega3) / (R - rho cos beta) [rad/s]."""
    return (u1 - p[P_R_BALL] * omega3) / (p[P_R_RIM] - p[P_RHO] * np.cos(beta))


@physics_kernel
def beta_rate(omega1, u3, p):
    """Rate of the height angle (20): beta_dot = (u3 + r omega1) / rho [rad/s]."""
    return (u3 + p[P_R_BALL] * omega1) / p[P_RHO]


@physics_kernel
def angle_rates(beta, omega1, omega3, u1, u3, p):
    """Rates of the contact angles (19)-(20): (alpha_dot, beta_dot) [rad/s]."""
    return alpha_rate(beta, omega3, u1, p), beta_rate(omega1, u3, p)


@physics_kernel
def centre_position(beta, p):
    """Ball centre in cylindrical coordinates about the rim's axis (12): (d, z) [m].

    d = R - rho cos(beta) is the horizontal distance from the rim's axis, z = rho sin(beta)
    the height above the rim's middle plane.
    """
    rho = p[P_RHO]
    return p[P_R_RIM] - rho * np.cos(beta), rho * np.sin(beta)


@physics_kernel
def centre_velocity(beta, omega1, omega3, u1, u3, p):
    """Velocity of the ball centre (13): (radial, vertical, tangential) components [m/s].

    radial = beta_dot rho sin(beta), vertical = beta_dot rho cos(beta),
    tangential = alpha_dot (R - rho cos(beta)) = u1 - r omega3.
    """
    rho = p[P_RHO]
    beta_dot = (u3 + p[P_R_BALL] * omega1) / rho
    tangential = u1 - p[P_R_BALL] * omega3
    return beta_dot * rho * np.sin(beta), beta_dot * rho * np.cos(beta), tangential
