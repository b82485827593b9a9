"""The swish (clean make) window of a shot in vacuum, computed as pure geometry without the solver's shot code;
shared by tests/solver/test_shot_checks.py (which states the method and checks it against a sampled path) and
tests/workflows/test_shot_probability.py.

The ball's centre follows the parabola x(t) = -L + v cos(theta) t, z(t) = -h + v sin(theta) t - g t^2 / 2 in the
vertical plane through the hoop's axis (frame of docs/shots.md), and touches the ring exactly when it comes within
rho = r + a of the ring's centre circle (radius R in the plane z = 0): the minima of two quartics in t.
"""

from __future__ import annotations

import math

import numpy as np
from numpy.polynomial import polynomial as poly

G = 9.81  # [m/s^2] paper Table 1
FREE_THROW = (4.19, 0.92)  # [m] distance from the hoop's axis, height of the rim plane above the release
PAPER_RING = dict(R=0.225, a=0.01, r=0.12)  # [m] paper Table 1 (inner diameter 2 (R - a) = 0.43 m)


def regulation_ring(rod: float, inner_diameter: float = 0.450) -> dict:
    """A FIBA ring [m]: inner diameter 450-459 mm, rod diameter 16-20 mm; the ball of Table 1."""
    a = rod / 2.0
    return dict(R=inner_diameter / 2.0 + a, a=a, r=0.12)


def centre_path(v: float, theta: float, L: float, h: float):
    """Polynomial coefficients (lowest first) of the centre's x(t) and z(t) [m], t [s]."""
    return np.array([-L, v * math.cos(theta)]), np.array([-h, v * math.sin(theta), -G / 2.0])


def descending_time(v: float, theta: float, h: float, depth: float) -> float:
    """Time [s] at which the descending centre is ``depth`` [m] below the rim plane (NaN if never there)."""
    vz = v * math.sin(theta)
    disc = vz * vz - 2.0 * G * (h - depth)
    return (vz + math.sqrt(disc)) / G if disc >= 0 else math.nan


def min_clearance2(v: float, theta: float, L: float, h: float, ring: dict) -> float:
    """Least squared distance [m^2] of the centre from the ring's centre circle, from the release
    until the centre is rho below the rim plane (exact: the minima of two quartics)."""
    rho = ring["r"] + ring["a"]
    t_end = descending_time(v, theta, h, rho)
    if not math.isfinite(t_end):
        return -math.inf
    x, z = centre_path(v, theta, L, h)
    best = math.inf
    for side in (1.0, -1.0):
        dx = poly.polyadd(x, [-side * ring["R"]])
        f = poly.polyadd(poly.polymul(dx, dx), poly.polymul(z, z))
        times = [0.0, t_end] + [t.real for t in poly.polyroots(poly.polyder(f))
                                if abs(t.imag) < 1e-12 and 0.0 < t.real < t_end]
        best = min(best, min(poly.polyval(t, f) for t in times))
    return best


def is_swish(v: float, theta: float, L: float, h: float, ring: dict) -> bool:
    """Whether the shot passes through the ring without touching it (vacuum, in-plane)."""
    t_cross = descending_time(v, theta, h, 0.0)
    if not math.isfinite(t_cross):
        return False
    x_cross = poly.polyval(t_cross, centre_path(v, theta, L, h)[0])
    return abs(x_cross) < ring["R"] and min_clearance2(v, theta, L, h, ring) > (ring["r"] + ring["a"]) ** 2


def speed_through_centre(theta: float, L: float, h: float) -> float:
    """Release speed [m/s] whose centre parabola passes through the ring's centre (closed form)."""
    return math.sqrt(G * L * L / (2.0 * math.cos(theta) ** 2 * (L * math.tan(theta) - h)))


def bisect_edge(inside, v_in: float, v_out: float, steps: int = 60) -> float:
    """The edge between a speed where ``inside(v)`` holds and one where it does not [m/s]."""
    assert inside(v_in) and not inside(v_out)
    for _ in range(steps):
        mid = 0.5 * (v_in + v_out)
        v_in, v_out = (mid, v_out) if inside(mid) else (v_in, mid)
    return v_in


def swish_window(theta: float, L: float, h: float, ring: dict, swish=None) -> tuple[float, float]:
    """(lowest, highest) swish speed [m/s] at elevation ``theta`` [rad], bisected from the speed
    through the centre; ``swish(v)`` decides a speed (default: the geometry of :func:`is_swish`)."""
    swish = swish or (lambda v: is_swish(v, theta, L, h, ring))
    v0 = speed_through_centre(theta, L, h)
    return bisect_edge(swish, v0, 0.95 * v0), bisect_edge(swish, v0, 1.05 * v0)
