"""Free flight of the ball's centre after separation (docs/outcome-studies.md, rule 4): in or out.

From the separation state, the centre is at horizontal radius d = R - rho cos(beta) and height
z = rho sin(beta) (12); its velocity is radial beta_dot rho sin(beta), vertical
beta_dot rho cos(beta), tangential alpha_dot (R - rho cos(beta)), with
alpha_dot = (u1 - r omega3)/(R - rho cos beta) and beta_dot = (u3 + r omega1)/rho (19), (20).
The centre follows a parabola under gravity -g to the first instant it is at z <= 0 while
descending (at once if z <= 0 already); with air (rho_air > 0, ``solver.physics.air``) it flies
under gravity and the quadratic drag -k |v| v instead, integrated by :func:`drag_landing_distance`.
The ball falls in (a score) if the centre's horizontal distance from the rim's axis is then < R
(:func:`lands_inside`); the engine's rules turn that into the outcome codes ``fall_in`` / ``fall_out``.
"""

from __future__ import annotations

import numpy as np

from rimroll.solver._compile import engine_kernel
from rimroll.solver.physics import air, kinematics
from rimroll.solver.physics.params import P_G, P_R_RIM

FLIGHT_STEPS = 256
"""Classical Runge-Kutta steps per estimated flight time of a flight with drag: the landing point is
then exact to ~(k |v| h)^4 relative (below 1e-12 m for a basketball in air)."""
DRAG_STEP = 0.05
"""Largest step of a flight with drag, as a fraction of the drag's relaxation time 1 / (k |v|): keeps the
Runge-Kutta steps accurate and stable however strong the drag (|v| never exceeds max(|v0|, sqrt(g/k)))."""
MAX_FLIGHT_STEPS = 1 << 20
"""Bound on the steps of one flight with drag (a drag a million times air's takes ~1e4). A flight that
has not landed by then falls at its terminal speed almost straight down: the landing is taken where it is."""


@engine_kernel
def landing_time(z, v_z, g):
    """First time [s] >= 0 at which z + v_z t - g t^2 / 2 <= 0 while descending (0 if z <= 0)."""
    if z <= 0.0:
        return 0.0
    root = np.sqrt(v_z * v_z + 2.0 * g * z)
    if v_z >= 0.0:
        return (v_z + root) / g
    return 2.0 * z / (root - v_z)  # same root, without cancellation


@engine_kernel
def landing_distance(beta, omega1, omega3, u1, u3, p):
    """Horizontal distance [m] of the centre from the rim's axis where the flight reaches z = 0."""
    d, z = kinematics.centre_position(beta, p)
    v_rad, v_z, v_tan = kinematics.centre_velocity(beta, omega1, omega3, u1, u3, p)
    k = air.drag_rate(p)
    if k > 0.0:
        return drag_landing_distance(d, z, v_rad, v_z, v_tan, k, p[P_G])
    tf = landing_time(z, v_z, p[P_G])
    x = d + v_rad * tf
    yt = v_tan * tf
    return np.sqrt(x * x + yt * yt)


@engine_kernel
def lands_inside(beta, omega1, omega3, u1, u3, p):
    """Whether a ball separating from the rim in the given state comes down inside the rim (a score)."""
    return landing_distance(beta, omega1, omega3, u1, u3, p) < p[P_R_RIM]


@engine_kernel
def drag_acceleration(vx, vy, vz, k, g):
    """Acceleration [m/s^2] of the centre in flight: gravity -g along z and the drag -k |v| v."""
    c = -k * np.sqrt(vx * vx + vy * vy + vz * vz)
    return c * vx, c * vy, c * vz - g


@engine_kernel
def drag_step(x, y, z, vx, vy, vz, h, k, g):
    """One classical Runge-Kutta step of length h [s] of the flight with drag; the new
    (x, y, z [m], vx, vy, vz [m/s])."""
    a1x, a1y, a1z = drag_acceleration(vx, vy, vz, k, g)
    b = 0.5 * h
    v2x, v2y, v2z = vx + b * a1x, vy + b * a1y, vz + b * a1z
    a2x, a2y, a2z = drag_acceleration(v2x, v2y, v2z, k, g)
    v3x, v3y, v3z = vx + b * a2x, vy + b * a2y, vz + b * a2z
    a3x, a3y, a3z = drag_acceleration(v3x, v3y, v3z, k, g)
    v4x, v4y, v4z = vx + h * a3x, vy + h * a3y, vz + h * a3z
    a4x, a4y, a4z = drag_acceleration(v4x, v4y, v4z, k, g)
    s = h / 6.0
    return (x + s * (vx + 2.0 * v2x + 2.0 * v3x + v4x), y + s * (vy + 2.0 * v2y + 2.0 * v3y + v4y),
            z + s * (vz + 2.0 * v2z + 2.0 * v3z + v4z), vx + s * (a1x + 2.0 * a2x + 2.0 * a3x + a4x),
            vy + s * (a1y + 2.0 * a2y + 2.0 * a3y + a4y), vz + s * (a1z + 2.0 * a2z + 2.0 * a3z + a4z))


@engine_kernel
def hermite(q0, dq0, q1, dq1, h, theta):
    """The cubic through q0, q1 [m] with slopes dq0, dq1 [m/s] over a step h [s], at theta in [0, 1]."""
    t2 = theta * theta
    t3 = t2 * theta
    return ((2.0 * t3 - 3.0 * t2 + 1.0) * q0 + (t3 - 2.0 * t2 + theta) * h * dq0 + (-2.0 * t3 + 3.0 * t2) * q1
            + (t3 - t2) * h * dq1)


@engine_kernel
def drag_landing_distance(d, z, v_rad, v_z, v_tan, k, g):
    """Horizontal distance [m] of the centre from the rim's axis where a flight under gravity g
    [m/s^2] and the drag -k |v| v (k [1/m]) from height z, distance d [m] and velocity (radial,
    vertical, tangential) [m/s] first reaches z = 0 (d itself if z <= 0): classical Runge-Kutta
    steps, FLIGHT_STEPS per estimated flight time (the parabola's, or z over the terminal speed
    sqrt(g/k) if longer) and at most DRAG_STEP of the drag's relaxation time, the crossing located
    on the step's cubic Hermite interpolant."""
    if z <= 0.0:
        return d
    t_fall = max(landing_time(z, v_z, g), z * np.sqrt(k / g))
    speed = max(np.sqrt(v_rad * v_rad + v_z * v_z + v_tan * v_tan), np.sqrt(g / k))  # |v| stays below this
    h = min(t_fall / FLIGHT_STEPS, DRAG_STEP / (k * speed))
    x, y, vx, vy, vz = d, 0.0, v_rad, v_tan, v_z
    for _ in range(MAX_FLIGHT_STEPS):
        x1, y1, z1, vx1, vy1, vz1 = drag_step(x, y, z, vx, vy, vz, h, k, g)
        if z1 <= 0.0:
            lo, hi = 0.0, 1.0  # z(lo) > 0 >= z(hi) on the step's cubic
            for _ in range(60):
                mid = 0.5 * (lo + hi)
                if hermite(z, vz, z1, vz1, h, mid) > 0.0:
                    lo = mid
                else:
                    hi = mid
            xe = hermite(x, vx, x1, vx1, h, hi)
            ye = hermite(y, vy, y1, vy1, h, hi)
            return np.sqrt(xe * xe + ye * ye)
        x, y, z, vx, vy, vz = x1, y1, z1, vx1, vy1, vz1
    return np.sqrt(x * x + y * y)
