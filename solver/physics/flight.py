"""Free flight of the ball's centre after separation (docs/outcome-studies.md, rule 4): in or out.

From the separation state, the centre is at horizontal radius d = R - rho cos(beta) and height
z = rho sin(beta) (12); its velocity is radial beta_dot rho sin(beta), vertical
beta_dot rho cos(beta), tangential alpha_dot (R - rho cos(beta)), with
alpha_dot = (u1 - r omega3)/(R - rho cos beta) and beta_dot = (u3 + r omega1)/rho (19), (20).
The centre follows a parabola under gravity -g to the first instant it is at z <= 0 while
descending (at once if z <= 0 already). The ball falls in (a score) if the centre's horizontal
distance from the rim's axis is then < R (:func:`lands_inside`); the engine's rules turn that into
the outcome codes ``fall_in`` / ``fall_out``.
"""

from __future__ import annotations

import numpy as np

from rimroll.solver._compile import kernel
from rimroll.solver.physics import kinematics
from rimroll.solver.physics.params import P_G, P_R_RIM


@kernel
def landing_time(z, v_z, g):
    """First time [s] >= 0 at which z + v_z t - g t^2 / 2 <= 0 while descending (0 if z <= 0)."""
    if z <= 0.0:
        return 0.0
    root = np.sqrt(v_z * v_z + 2.0 * g * z)
    if v_z >= 0.0:
        return (v_z + root) / g
    return 2.0 * z / (root - v_z)  # same root, without cancellation


@kernel
def landing_distance(beta, omega1, omega3, u1, u3, p):
    """Horizontal distance [m] of the centre from the rim's axis where the flight reaches z = 0."""
    d, z = kinematics.centre_position(beta, p)
    v_rad, v_z, v_tan = kinematics.centre_velocity(beta, omega1, omega3, u1, u3, p)
    tf = landing_time(z, v_z, p[P_G])
    x = d + v_rad * tf
    yt = v_tan * tf
    return np.sqrt(x * x + yt * yt)


@kernel
def lands_inside(beta, omega1, omega3, u1, u3, p):
    """Whether a ball separating from the rim in the given state comes down inside the rim (a score)."""
    return landing_distance(beta, omega1, omega3, u1, u3, p) < p[P_R_RIM]
