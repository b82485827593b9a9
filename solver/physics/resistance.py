"""Coulomb-type rolling and drilling resistance: contact moments proportional to the normal force.

The linear contact moment (83) of the paper grows with the angular velocity. The classical
alternative for a ball on a hard surface is a *dry* (Coulomb-type) resistance, a moment whose size
is fixed by the normal force and whose direction opposes the rotation:

* **rolling resistance** (Coulomb 1785; the "coefficient of rolling friction" as a length, e.g.
  V. L. Popov, *Contact Mechanics and Friction*, 2nd ed., Springer 2017, Sect. 17.1):
  M = -c_r F2 omega_t / |omega_t| on the rolling components omega_t = (omega1, 0, omega3) of the
  ball's angular velocity (the components tangent to the contact); c_r [m] is the arm by which the
  normal force's resultant leads the contact point;
* **drilling (pivoting) resistance** (Contensou 1963; R. I. Leine and C. Glocker, "A set-valued
  force law for spatial Coulomb-Contensou friction", Eur. J. Mech. A/Solids 22 (2003) 193-216,
  whose drilling moment for a small contact patch is mu F2 times a length of the patch):
  M2 = -c_d F2 sign(omega2) about the contact normal n2; c_d [m] is that contact length.

Both are pure moments (no force), so they add nothing to the normal force F2 (``solver.physics.loads``),
and F2 here is the normal force of the state: (31) while rolling, (41) while slipping (the ball's
other loads of the scene table add no normal force either: air drag acts along the centre's
velocity, which is tangent to the torus the centre moves on).

**Regularisation.** sign(x) and x/|x| are replaced by x / sqrt(x^2 + OMEGA_SMOOTH^2) (rolling:
x = omega_t, |x| its norm). The moment then differs from the dry law by a relative
OMEGA_SMOOTH^2 / (2 |x|^2) where |x| >> OMEGA_SMOOTH (5e-5 at 1 1/s), its power
-c F2 |x|^2 / sqrt(|x|^2 + OMEGA_SMOOTH^2) is never positive while F2 >= 0, and it relaxes a rate
through zero at c F2 / (J OMEGA_SMOOTH) (about 100 1/s for c_d = 1 mm): the equations stay smooth
for the integrator. A ball on the rim always rolls (|omega_t| >= |beta_dot| rho / r and the orbit's
alpha_dot), so the smoothing matters only where omega2 passes through zero.
"""

from __future__ import annotations

import numpy as np

from rimroll.solver._jit import physics_kernel
from rimroll.solver.physics import slipping
from rimroll.solver.physics.params import P_C_D, P_C_R

OMEGA_SMOOTH = 1e-2
"""Angular velocity [1/s] below which the dry resistances are smoothed (see the module's text)."""


@physics_kernel
def coulomb_rolling(beta, omega1, omega2, omega3, u1, u3, p):
    """The Coulomb rolling-resistance moment as a load (``solver.physics.loads``):
    M = -c_r F2 (omega1, 0, omega3) / sqrt(omega1^2 + omega3^2 + OMEGA_SMOOTH^2) [N m], no force.

    c_r = p[P_C_R] [m]; F2 [N] the normal force of the state (rolling: u1 = u3 = 0)."""
    F2 = slipping.slipping_normal_force(beta, omega1, omega3, u1, u3, p)
    k = -p[P_C_R] * F2 / np.sqrt(omega1 * omega1 + omega3 * omega3 + OMEGA_SMOOTH * OMEGA_SMOOTH)
    return k * omega1, 0.0, k * omega3, 0.0, 0.0, 0.0


@physics_kernel
def coulomb_drilling(beta, omega1, omega2, omega3, u1, u3, p):
    """The Coulomb drilling-resistance moment as a load: M = (0, -c_d F2 omega2 / sqrt(omega2^2 +
    OMEGA_SMOOTH^2), 0) [N m], no force. c_d = p[P_C_D] [m]; F2 [N] the normal force of the state."""
    F2 = slipping.slipping_normal_force(beta, omega1, omega3, u1, u3, p)
    return 0.0, -p[P_C_D] * F2 * omega2 / np.sqrt(omega2 * omega2 + OMEGA_SMOOTH * OMEGA_SMOOTH), 0.0, 0.0, 0.0, 0.0
