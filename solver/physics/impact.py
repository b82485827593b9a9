"""The single-point impact of a rigid sphere on the ring or the board: restitution and Coulomb friction.

The ball (mass m, radius r, moment of inertia J = j m r^2) touches a fixed surface at the point -r n
from its centre, n the unit normal of the surface pointing to the centre. An impulse P = P_n n + P_t
(P_t perpendicular to n) at that point changes the centre's velocity by dv = P / m and the spin by
domega = (-r n x P) / (j m r^2). The velocity of the contact point, u = v + omega x (-r n), changes by

    du = dv + domega x (-r n) = P / m + ((n x P) x n) / (j m) = (P_n / m) n + (1 + 1/j) P_t / m,

so the normal and the tangential impulses decouple (the normal through the contact passes through
the centre of a sphere). Normal law (Newton): v_n' = -e v_n, i.e. P_n = -m (1 + e) v_n (v_n < 0:
approaching). Tangential law (Coulomb, |P_t| <= mu P_n):

* stick: the contact point's tangential velocity u_t is brought to rest, P_t = -m u_t / (1 + 1/j),
  allowed while |P_t| <= mu P_n, i.e. |u_t| <= (1 + 1/j) mu (1 + e) |v_n|;
* slide otherwise: P_t = -mu P_n u_t / |u_t|, and u_t' = lam u_t with
  lam = 1 - (1 + 1/j) mu (1 + e) |v_n| / |u_t| in (0, 1].

Kinetic energy never increases. For one impulse P at one point of a rigid body the change of the
kinetic energy is P . (u + u') / 2 (u, u' the contact point's velocities before and after). Normal part:
P_n (v_n + v_n') / 2 = -m (1 + e) (1 - e) v_n^2 / 2 <= 0 for 0 <= e <= 1. Tangential part: stick,
P_t . u_t / 2 = -m |u_t|^2 / (2 (1 + 1/j)) <= 0; slide, -mu P_n |u_t| (1 + lam) / 2 <= 0. The loss is
zero only for e = 1 and u_t = 0 or mu = 0.
"""

from __future__ import annotations

import math


def impact(v, omega, n, r: float, j: float, e: float, mu: float):
    """Velocity [m/s] and angular velocity [1/s] (3-tuples) after the impact of a ball of radius ``r`` [m]
    and inertia factor ``j`` [-] with velocity ``v`` and spin ``omega`` at the contact point -r n (``n``
    the unit normal towards the centre), restitution ``e`` and friction ``mu``; and whether it stuck
    (True) or slid (False). An impact that is not approaching (v . n >= 0) changes nothing."""
    vx, vy, vz = v
    wx, wy, wz = omega
    nx, ny, nz = n
    v_n = vx * nx + vy * ny + vz * nz
    if v_n >= 0.0:
        return v, omega, True
    # contact point velocity u = v + omega x (-r n) = v - r omega x n
    ux = vx - r * (wy * nz - wz * ny)
    uy = vy - r * (wz * nx - wx * nz)
    uz = vz - r * (wx * ny - wy * nx)
    u_n = ux * nx + uy * ny + uz * nz
    tx, ty, tz = ux - u_n * nx, uy - u_n * ny, uz - u_n * nz
    slip = math.sqrt(tx * tx + ty * ty + tz * tz)
    p_n = -(1.0 + e) * v_n  # normal impulse per unit mass [m/s]
    factor = 1.0 + 1.0 / j
    stuck = slip <= factor * mu * p_n
    c = -1.0 / factor if stuck else -mu * p_n / slip
    px, py, pz = p_n * nx + c * tx, p_n * ny + c * ty, p_n * nz + c * tz  # impulse per unit mass
    # domega = -(n x P) / (j r) per unit mass
    dwx = -(ny * pz - nz * py) / (j * r)
    dwy = -(nz * px - nx * pz) / (j * r)
    dwz = -(nx * py - ny * px) / (j * r)
    return (vx + px, vy + py, vz + pz), (wx + dwx, wy + dwy, wz + dwz), stuck


def kinetic_energy(v, omega, m: float, r: float, j: float) -> float:
    """Kinetic energy [J] m |v|^2 / 2 + j m r^2 |omega|^2 / 2 of the ball."""
    return 0.5 * m * (sum(c * c for c in v) + j * r * r * sum(c * c for c in omega))
