"""Air resistance: quadratic drag on the ball's centre, on the rim and in the flight after separation.

The drag of a sphere at the Reynolds numbers of a basketball shot (Re ~ 1e5) is quadratic in the
speed of its centre (H. Okubo and M. Hubbard, "Dynamics of the basketball shot with application
to the free throw", J. Sports Sci. 24 (2006) 1303-1314, who take C_D ~ 0.5 for a basketball),

    F = -1/2 rho_air C_D A |v| v,   A = pi r^2,

applied at the centre; its moment about the contact point, r n2 x F, enters the equations of both
phases through the load machinery (``solver.physics.loads``: a force at the centre changes the
friction that keeps the contact at rest while rolling, and the rates of the slipping equations).
The centre moves on the torus of radius rho about the rim's middle circle, so its velocity
(V1, 0, V3) = (u1 - r omega3, 0, u3 + r omega1) in the n-basis is tangent to that torus and the
drag has no normal component: it leaves the normal force F2 as it is. Its power is
-1/2 rho_air C_D A |v|^3.

After separation the centre flies under gravity and the same drag (``solver.physics.flight``),
so the in/out rule integrates the flight instead of the parabola when rho_air > 0.

The Magnus force of the ball's spin is left out (its lift coefficient for a basketball is not
established; Okubo and Hubbard take C_L ~ 0.2-0.3 only for backspin shots).
"""

from __future__ import annotations

import numpy as np

from rimroll.solver._jit import physics_kernel
from rimroll.solver.physics.params import P_C_DRAG, P_M, P_R_BALL, P_RHO_AIR


@physics_kernel
def drag_rate(p):
    """k = rho_air C_D pi r^2 / (2 m) [1/m]: the drag deceleration of the centre is k |v|^2."""
    r = p[P_R_BALL]
    return 0.5 * p[P_RHO_AIR] * p[P_C_DRAG] * np.pi * r * r / p[P_M]


@physics_kernel
def air_drag(beta, omega1, omega2, omega3, u1, u3, p):
    """Quadratic air drag on the centre as a load: (0, 0, 0, F1, 0, F3) [N m, N] with
    F = -m k |V| V, V = (u1 - r omega3, 0, u3 + r omega1) [m/s] the velocity of the centre in the
    n-basis and k = :func:`drag_rate` [1/m]."""
    r = p[P_R_BALL]
    V1 = u1 - r * omega3
    V3 = u3 + r * omega1
    c = -p[P_M] * drag_rate(p) * np.sqrt(V1 * V1 + V3 * V3)
    return 0.0, 0.0, 0.0, c * V1, 0.0, c * V3
