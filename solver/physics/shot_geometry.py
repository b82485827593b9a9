"""The ring and the board of a shot: their sizes, and the distance of the ball's centre from them.

Frame (docs/shot-api.md): origin at the centre of the ring, z up (the rim plane z = 0 holds the centre
circle of the ring's tube), x from the shooter towards the board. The ring is the paper's torus (major
radius R, tube radius a); the ball (radius r) touches it when its centre is at the distance
rho = r + a from the centre circle. The board is a rectangle in a plane x = const facing the shooter.

Geometries:

* ``paper``: the ring of the paper's Table 1 (R = 0.225 m, a = 0.01 m: inner diameter 0.43 m).
* ``regulation``: a FIBA ring (Official Basketball Rules, Basketball Equipment: inner diameter
  450-459 mm, rod diameter 16-20 mm): the least inner diameter 0.450 m and a rod of 0.018 m
  (a = 0.009 m, R = 0.234 m).

Board (both geometries; FIBA Basketball Equipment): 1.80 m wide and 1.05 m tall, its face 0.151 m
from the ring's inner edge (x = R - a + 0.151), its lower edge 2.90 m above the floor, i.e. 0.15 m
below the upper edge of the ring (3.05 m): z from a - 0.15 to a - 0.15 + 1.05, y from -0.90 to 0.90.
Only its face is modelled (no edges, no support of the ring).
"""

from __future__ import annotations

import math
from typing import NamedTuple

GEOMETRIES = {
    "paper": dict(R=0.225, a=0.01),
    "regulation": dict(R=0.450 / 2.0 + 0.009, a=0.009),
}
"""The rings [m] by name: ``paper`` (Table 1), ``regulation`` (FIBA, 450 mm inner diameter, 18 mm rod)."""

BOARD_GAP = 0.151
"""[m] from the ring's inner edge to the board's face (FIBA)."""
BOARD_WIDTH = 1.80
"""[m] width of the board (FIBA)."""
BOARD_HEIGHT = 1.05
"""[m] height of the board (FIBA)."""
BOARD_BELOW_RING_TOP = 0.15
"""[m] from the ring's upper edge (3.05 m) down to the board's lower edge (2.90 m) (FIBA)."""


class Board(NamedTuple):
    """The board's face: the plane x = ``x`` [m], y in [-half_width, half_width], z in [z_low, z_high] [m]."""

    x: float
    half_width: float
    z_low: float
    z_high: float


def ring_of(geometry: str) -> dict:
    """The ring {"R": major radius, "a": tube radius} [m] of ``geometry``; ValueError names the allowed ones."""
    if not isinstance(geometry, str) or geometry not in GEOMETRIES:
        raise ValueError(f"`geometry` must be one of {', '.join(GEOMETRIES)}; got {geometry!r}")
    return dict(GEOMETRIES[geometry])


def board_of(R: float, a: float) -> Board:
    """The board [m] for a ring of major radius ``R`` and tube radius ``a`` [m] (FIBA placement)."""
    z_low = a - BOARD_BELOW_RING_TOP
    return Board(R - a + BOARD_GAP, 0.5 * BOARD_WIDTH, z_low, z_low + BOARD_HEIGHT)


def ring_distance(x: float, y: float, z: float, R: float) -> float:
    """Distance [m] of the point (x, y, z) [m] from the ring's centre circle (radius R [m], plane z = 0)."""
    return math.hypot(math.hypot(x, y) - R, z)


def ring_normal(x: float, y: float, z: float, R: float) -> tuple[float, float, float]:
    """Unit normal of the ring's tube at the contact with a ball centred at (x, y, z) [m]: from the
    nearest point of the centre circle to the ball's centre (points towards the ball)."""
    q = math.hypot(x, y)
    if q > 0.0:
        cx, cy = R * x / q, R * y / q
    else:  # on the axis: every point of the circle is nearest; take the one on +x
        cx, cy = R, 0.0
    dx, dy, dz = x - cx, y - cy, z
    d = math.sqrt(dx * dx + dy * dy + dz * dz)
    return dx / d, dy / d, dz / d
