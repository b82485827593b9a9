"""The release of a shot: the initial state of the ball's centre and spin, and the speed that reaches the hoop.

Frame of docs/shot-api.md: origin at the ring's centre, z up, x towards the board.
"""

from __future__ import annotations

import math

import numpy as np


def release_state(speed, angle, distance, height, lateral, azimuth, backspin, sidespin):
    """Position [m], velocity [m/s] and angular velocity [1/s] of the ball at the release, each a
    tuple of three arrays (x, y, z). The throw direction d = (cos azimuth, sin azimuth, 0); backspin
    is about the horizontal axis d x z (so positive backspin turns the ball's top back towards the
    shooter), sidespin about +z."""
    ca, sa = np.cos(azimuth), np.sin(azimuth)
    ce, se = np.cos(angle), np.sin(angle)
    position = (-distance + 0.0 * speed, lateral + 0.0 * speed, -height + 0.0 * speed)
    velocity = (speed * ce * ca, speed * ce * sa, speed * se)
    # d x z = (sin az, -cos az, 0): the axis about which backspin turns the top against d
    omega = (backspin * sa, -backspin * ca, sidespin + 0.0 * backspin)
    return position, velocity, omega


def vacuum_reach_speed(angle: float, distance: float, height: float, g: float) -> float:
    """Speed [m/s] at elevation ``angle`` [rad] whose vacuum parabola passes through the point
    ``distance`` [m] away and ``height`` [m] up: sqrt(g L^2 / (2 cos^2 angle (L tan angle - h))); NaN
    if L tan(angle) <= h or cos(angle) <= 0."""
    c = math.cos(angle)
    lift = distance * math.tan(angle) - height if c > 0 else -1.0
    if lift <= 0.0:
        return math.nan
    return math.sqrt(g * distance * distance / (2.0 * c * c * lift))


def reach_speed(angle: float, distance: float, height: float, params) -> float:
    """:func:`vacuum_reach_speed` for ``params.rho_air == 0``; with drag, the speed found by shooting
    (the flight with drag, ``solver.physics.flight.drag_step``, to the hoop's x, bisected on the speed)."""
    g = params.g
    v0 = vacuum_reach_speed(angle, distance, height, g)
    if params.rho_air == 0.0 or not math.isfinite(v0):
        return v0
    from rimroll.solver.physics.shot_flight import drag_height_at

    k = 0.5 * params.rho_air * params.C_D * math.pi * params.r ** 2 / params.m
    lo, hi = v0, v0
    while drag_height_at(hi, angle, distance, height, k, g) < 0.0:
        hi *= 1.1
        if hi > 1e3 * v0:
            return math.nan
    for _ in range(200):
        mid = 0.5 * (lo + hi)
        if drag_height_at(mid, angle, distance, height, k, g) < 0.0:
            lo = mid
        else:
            hi = mid
        if hi - lo <= 1e-13 * hi:
            break
    return 0.5 * (lo + hi)
