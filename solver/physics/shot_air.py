"""The ball's flight in air between impacts: drag, the opt-in Magnus lift, and compiled Runge-Kutta steps.

Acceleration of the centre (velocity v [m/s], spin omega [1/s], constant in flight: no aerodynamic
torque is modelled):

    a = -g e_z - k |v| v + k_L (C_L(S) / S) r (omega x v),

with k = rho_air C_D pi r^2 / (2 m) [1/m] the drag rate of ``physics.air`` (Okubo and Hubbard, J.
Sports Sci. 24 (2006) 1303: C_D ~ 0.5) and, with lift on, k_L = rho_air pi r^2 / (2 m) [1/m]: this is
the lift F_L = 1/2 rho_air A C_L |v|^2 along omega x v / |omega x v| (A = pi r^2), written with the
spin ratio S = r |omega_perp| / |v| (omega_perp: the spin's part across v; |omega x v| = |omega_perp|
|v|). C_L(S) is the bilinear fit of Sawicki, Hubbard and Stronge, "How to hit home runs", Am. J. Phys.
71 (2003) 1152, eq. (9): C_L = 1.5 S for S <= 0.1 and 0.09 + 0.6 S above (measured on baseballs; a
basketball's pebbled surface makes it a rough sphere as well, an assumption: no fit measured on
basketballs is published with code). The lift is perpendicular to v, so it does no work: the speed
changes only through drag (which slows it) and gravity: over a time t it grows by at most g t (the
bound of the contact search's gates).

:func:`flight_steps` is the compiled integrator of the shot's flight with air (``physics.shot_flight``):
classical Runge-Kutta steps of a fixed length, each followed by the gates of the contact search (may the
centre come within rho of the ring's centre circle, may x reach the board's plane, on that step).
"""

from __future__ import annotations

import math

from rimroll.solver._jit import physics_kernel as kernel

LIFT_SLOPE = 1.5
"""dC_L/dS below the knee of the fit (Sawicki, Hubbard and Stronge 2003)."""
LIFT_KNEE = 0.1
"""Spin ratio S of the knee of the fit."""
LIFT_OFFSET, LIFT_TAIL_SLOPE = 0.09, 0.6
"""C_L = 0.09 + 0.6 S above the knee."""
PATH_MARGIN = 1.1
"""Factor on the bound of a step's path length (the Hermite piece's own speed may exceed the ends')."""


@kernel
def lift_coefficient(s):
    """C_L [-] at the spin ratio ``s`` = r |omega_perp| / |v| [-] (Sawicki, Hubbard and Stronge 2003)."""
    if s <= LIFT_KNEE:
        return LIFT_SLOPE * s
    return LIFT_OFFSET + LIFT_TAIL_SLOPE * s


@kernel
def acceleration(vx, vy, vz, wx, wy, wz, k, k_lift, r, g):
    """Acceleration (ax, ay, az) [m/s^2] of the centre moving with (vx, vy, vz) [m/s], spinning with
    (wx, wy, wz) [1/s]: gravity g [m/s^2], drag rate k [1/m], lift rate k_lift [1/m] (0: no lift), ball
    radius r [m] (see the module doc)."""
    speed = math.sqrt(vx * vx + vy * vy + vz * vz)
    ax = -k * speed * vx
    ay = -k * speed * vy
    az = -k * speed * vz - g
    if k_lift > 0.0 and speed > 0.0:
        cx = wy * vz - wz * vy
        cy = wz * vx - wx * vz
        cz = wx * vy - wy * vx
        cross = math.sqrt(cx * cx + cy * cy + cz * cz)
        if cross > 0.0:
            s = r * cross / (speed * speed)
            f = k_lift * r * lift_coefficient(s) / s
            ax += f * cx
            ay += f * cy
            az += f * cz
    return ax, ay, az


@kernel
def flight_steps(rows, gates, n, w, k, k_lift, r, g, h, t_until, z_stop, ring):
    """Runge-Kutta 4 steps of length ``h`` [s] from row ``n - 1`` of ``rows`` (rows (t, x, y, z, vx, vy,
    vz) [s, m, m/s]), spin ``w`` (3,) [1/s], rates ``k``, ``k_lift`` [1/m], radius ``r`` [m], gravity
    ``g``, until a row reaches ``t_until`` [s], or its z is below ``z_stop`` [m] descending, or ``rows``
    is full. ``ring`` = (R, rho, level) [m]. ``gates[i]`` of step i (rows i to i + 1): 1 if the centre may come
    within ``rho`` of the ring's centre circle (radius ``R``), plus 2 if its x may reach ``level``; the bound: the
    distance and x are 1-Lipschitz along the path, whose length over the step is at most
    PATH_MARGIN (largest end speed + g h) h. Returns the number of filled rows."""
    cap = rows.shape[0]
    R, rho, level = ring
    while n < cap:
        t0, x, y, z, vx, vy, vz = rows[n - 1, 0], rows[n - 1, 1], rows[n - 1, 2], rows[n - 1, 3], rows[n - 1, 4], \
            rows[n - 1, 5], rows[n - 1, 6]
        if n > 1 and (t0 >= t_until or (z < z_stop and vz < 0.0)):
            break
        a1 = acceleration(vx, vy, vz, w[0], w[1], w[2], k, k_lift, r, g)
        b = 0.5 * h
        v2x, v2y, v2z = vx + b * a1[0], vy + b * a1[1], vz + b * a1[2]
        a2 = acceleration(v2x, v2y, v2z, w[0], w[1], w[2], k, k_lift, r, g)
        v3x, v3y, v3z = vx + b * a2[0], vy + b * a2[1], vz + b * a2[2]
        a3 = acceleration(v3x, v3y, v3z, w[0], w[1], w[2], k, k_lift, r, g)
        v4x, v4y, v4z = vx + h * a3[0], vy + h * a3[1], vz + h * a3[2]
        a4 = acceleration(v4x, v4y, v4z, w[0], w[1], w[2], k, k_lift, r, g)
        s = h / 6.0
        rows[n, 0] = t0 + h
        rows[n, 1] = x + s * (vx + 2.0 * v2x + 2.0 * v3x + v4x)
        rows[n, 2] = y + s * (vy + 2.0 * v2y + 2.0 * v3y + v4y)
        rows[n, 3] = z + s * (vz + 2.0 * v2z + 2.0 * v3z + v4z)
        rows[n, 4] = vx + s * (a1[0] + 2.0 * a2[0] + 2.0 * a3[0] + a4[0])
        rows[n, 5] = vy + s * (a1[1] + 2.0 * a2[1] + 2.0 * a3[1] + a4[1])
        rows[n, 6] = vz + s * (a1[2] + 2.0 * a2[2] + 2.0 * a3[2] + a4[2])
        speed = max(math.sqrt(vx * vx + vy * vy + vz * vz),
                    math.sqrt(rows[n, 4] ** 2 + rows[n, 5] ** 2 + rows[n, 6] ** 2)) + g * h
        length = PATH_MARGIN * speed * h
        d0 = math.hypot(math.hypot(x, y) - R, z)
        d1 = math.hypot(math.hypot(rows[n, 1], rows[n, 2]) - R, rows[n, 3])
        gate = 1 if 0.5 * (d0 + d1 - length) <= rho else 0
        if 0.5 * (x + rows[n, 1] + length) >= level:
            gate += 2
        gates[n - 1] = gate
        n += 1
    return n
