"""The paper's contact frame (n1, n2, n3) of Sect. 2.1 in the shot's frame, both ways.

Shot frame (docs/shot-api.md): origin at the ring's centre, z up; the paper's fixed basis is
e1 = x, e2 = y, e3 = z. With h = sin(alpha) e1 - cos(alpha) e2 (horizontal, from the axis towards the
contact), the paper's (2)-(4) read n1 = cos(alpha) e1 + sin(alpha) e2, n2 = -cos(beta) h + sin(beta) e3
(the rim's normal at the contact, towards the ball's centre), n3 = sin(beta) h + cos(beta) e3, and the
centre is G = R h + rho n2 (12). The angular velocity is omega = omega1 n1 + omega2 n2 + omega3 n3 and
the contact point's velocity v_C = v_G + omega x (-r n2) = u1 n1 + u3 n3 (+ a normal part, zero on the
rim). A rolling ball (u = 0) has v_G = -r omega3 n1 + r omega1 n3 ((19)-(20) with (13)).
"""

from __future__ import annotations

import math


def basis(alpha: float, beta: float):
    """(n1, n2, n3), 3-tuples in the shot frame, at the contact angles ``alpha``, ``beta`` [rad]."""
    sa, ca, sb, cb = math.sin(alpha), math.cos(alpha), math.sin(beta), math.cos(beta)
    h = (sa, -ca, 0.0)
    n1 = (ca, sa, 0.0)
    n2 = (-cb * h[0], -cb * h[1], sb)
    n3 = (sb * h[0], sb * h[1], cb)
    return n1, n2, n3


def _dot(a, b) -> float:
    return a[0] * b[0] + a[1] * b[1] + a[2] * b[2]


def to_rim(position, velocity, spin, R: float, r: float):
    """(alpha, beta [rad], omega1, omega2, omega3 [1/s], u1, u3, u_n [m/s]) of a ball centred at
    ``position`` [m] (at the distance rho from the centre circle) moving with ``velocity`` [m/s] and
    spinning with ``spin`` [1/s]; u_n is the contact point's velocity along n2."""
    x, y, z = position
    q = math.hypot(x, y)
    alpha = math.atan2(x, -y)
    beta = math.atan2(z, R - q)
    n1, n2, n3 = basis(alpha, beta)
    wx, wy, wz = spin
    # v_C = v - r omega x n2
    c = (wy * n2[2] - wz * n2[1], wz * n2[0] - wx * n2[2], wx * n2[1] - wy * n2[0])
    v_c = tuple(velocity[i] - r * c[i] for i in range(3))
    return (alpha, beta, _dot(spin, n1), _dot(spin, n2), _dot(spin, n3), _dot(v_c, n1), _dot(v_c, n3),
            _dot(v_c, n2))


def from_rim(alpha: float, beta: float, omega1: float, omega2: float, omega3: float, R: float, r: float,
             rho: float, u1: float = 0.0, u3: float = 0.0):
    """Position [m], velocity [m/s] and spin [1/s] (3-tuples, shot frame) of a ball on the rim in the
    paper's state (``alpha``, ``beta``, ``omega1``, ``omega2``, ``omega3``) with the contact point's slip
    velocity (``u1``, ``u3``) [m/s] (0, 0: rolling). The centre's velocity is v_G = (u1 - r omega3) n1 +
    (u3 + r omega1) n3 (the slipping model's V1, V3, Sect. 5.2; rolling: (19)-(20) with (13))."""
    n1, n2, n3 = basis(alpha, beta)
    h = (math.sin(alpha), -math.cos(alpha), 0.0)
    position = tuple(R * h[i] + rho * n2[i] for i in range(3))
    velocity = tuple((u1 - r * omega3) * n1[i] + (u3 + r * omega1) * n3[i] for i in range(3))
    spin = tuple(omega1 * n1[i] + omega2 * n2[i] + omega3 * n3[i] for i in range(3))
    return position, velocity, spin
