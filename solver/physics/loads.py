"""External loads on the ball and what they add to the equations of motion of each phase.

A term of a scene (``solver.engine.scenes``: a rolling resistance, air drag, ...) is a function of
the state giving a load in the contact basis (n1, n2, n3),

    load = (M1, M2, M3, F1, F2, F3),

a moment M about the ball's centre [N m] and a force F at its centre [N]. The equations of every
phase follow from the Newton-Euler equations (24)-(25) with the load added (``solver.physics.slipping``
writes them as omega_dot = a + (-F3c, 0, F1c)/(j m r), u_dot = b + (1+j)/(j m) (F1c, F3c) for the
contact friction (F1c, F3c)): the load adds

    da = M / (j m r^2),   db1 = r da3 + F1 / m,   db3 = -r da1 + F3 / m,   dF2c = -F2

to the rates a, b without friction and to the normal contact force. While rolling, the friction
that keeps u_dot = 0 changes by -(j m / (1+j)) db, which gives the rolling rates of
:func:`rolling_rates` and the contact forces of :func:`contact_forces`. So one load serves both
phases and the switches between them (``solver.physics.switching``), as the contact moment of (83)
does: :func:`contact_moment` is that moment written as a load, whose rolling rates are exactly
-k_r omega1, -k_d omega2, -k_r omega3.

Every function takes scalars (compiled) or, through ``solver._jit.vectorised``, numpy arrays.
"""

from __future__ import annotations

from numba import types
from numba.extending import overload

from rimroll.solver._jit import physics_kernel
from rimroll.solver.physics.constants import constants


def at(load_fn, beta, omega1, omega2, omega3, u1, u3, p):
    """The load of the scene's terms at the state (``load_fn(beta, omega1, omega2, omega3, u1, u3, p)``),
    or None where the scene has none (``load_fn`` None): the functions that take a load then compile
    to the equations without one. In compiled code the choice is made by the type of ``load_fn``
    (:func:`_at`), so neither case carries the other's code."""
    if load_fn is None:
        return None
    return load_fn(beta, omega1, omega2, omega3, u1, u3, p)


@overload(at, jit_options={"nogil": True})
def _at(load_fn, beta, omega1, omega2, omega3, u1, u3, p):
    if isinstance(load_fn, (types.NoneType, types.Omitted)):
        def none(load_fn, beta, omega1, omega2, omega3, u1, u3, p):
            return None
        return none

    def call(load_fn, beta, omega1, omega2, omega3, u1, u3, p):
        return load_fn(beta, omega1, omega2, omega3, u1, u3, p)
    return call


@physics_kernel
def rolling_rates(load, p):
    """What the load adds to (omega1_dot, omega2_dot, omega3_dot) of a rolling ball [1/s^2]."""
    r, R, rho, m, j, g, mu, k_r, k_d = constants(p)
    M1, M2, M3, F1, F2, F3 = load
    roll = (1.0 + j) * m * r
    return M1 / (roll * r) + F3 / roll, M2 / (j * m * r * r), M3 / (roll * r) - F1 / roll


@physics_kernel
def contact_forces(load, p):
    """What the load adds to the contact force (F1, F2, F3) of a rolling ball [N]: the friction that
    keeps the contact point at rest, and the normal force."""
    r, R, rho, m, j, g, mu, k_r, k_d = constants(p)
    M1, M2, M3, F1, F2, F3 = load
    da1 = M1 / (j * m * r * r)
    da3 = M3 / (j * m * r * r)
    k = j * m / (1.0 + j)
    return -k * (r * da3 + F1 / m), -F2, -k * (-r * da1 + F3 / m)


@physics_kernel
def free_rates(load, p):
    """What the load adds to the rates of a slipping ball without friction (``slipping.free_rates``):
    (da1, da2, da3 [1/s^2], db1, db3 [m/s^2], dF2 [N])."""
    r, R, rho, m, j, g, mu, k_r, k_d = constants(p)
    M1, M2, M3, F1, F2, F3 = load
    jmr2 = j * m * r * r
    da1 = M1 / jmr2
    da3 = M3 / jmr2
    return da1, M2 / jmr2, da3, r * da3 + F1 / m, -r * da1 + F3 / m, -F2


@physics_kernel
def power(load, omega1, omega2, omega3, v1, v2, v3):
    """The power of the load [W]: M . omega + F . v with v the velocity of the centre (n-basis, m/s)."""
    M1, M2, M3, F1, F2, F3 = load
    return M1 * omega1 + M2 * omega2 + M3 * omega3 + F1 * v1 + F2 * v2 + F3 * v3


@physics_kernel
def contact_moment(beta, omega1, omega2, omega3, u1, u3, p):
    """The contact moment of (83) as a load: M = -((1+j) m r^2 k_r omega1, j m r^2 k_d omega2,
    (1+j) m r^2 k_r omega3) [N m], no force. rimroll builds it into the rolling and slipping
    equations themselves (``rolling.rolling_rhs``, ``slipping.free_rates``); as a load it checks
    the load machinery against them."""
    r, R, rho, m, j, g, mu, k_r, k_d = constants(p)
    mr2 = m * r * r
    return (-(1.0 + j) * mr2 * k_r * omega1, -j * mr2 * k_d * omega2, -(1.0 + j) * mr2 * k_r * omega3,
            0.0, 0.0, 0.0)

