"""The flight of the ball's centre between impacts: the vacuum parabola, or the flight in air.

In vacuum the centre follows p(t) = p0 + v0 t - (0, 0, g t^2 / 2), one polynomial piece. In air
(rho_air > 0: drag, and the Magnus lift when switched on; ``physics.shot_air``) the flight is
integrated by classical Runge-Kutta steps of :data:`DRAG_STEP` in a compiled kernel
(``shot_air.flight_steps``) and each step is the cubic Hermite polynomial through its end positions
and velocities; a step is searched for a contact only if the kernel's bound allows one (its gates).
The spin does not change in flight (no aerodynamic torque).
"""

from __future__ import annotations

import math

import numpy as np

from rimroll.solver.physics.shot_air import flight_steps
from rimroll.solver.physics.shot_geometry import board_of

DRAG_STEP = 2e-3
"""[s] step of the flight in air (Runge-Kutta 4: position error ~1e-11 m over a shot)."""
CHUNK = 1024
"""Rows added to a flight's table of steps at a time."""
RING, PLANE = 1, 2
"""Bits of a step's gate: the ring may be touched, the board's plane may be reached."""


def hermite_coefficients(q0: float, dq0: float, q1: float, dq1: float, h: float) -> np.ndarray:
    """Coefficients (lowest first, in t from 0 to h [s]) of the cubic with values q0, q1 and slopes dq0, dq1."""
    c2 = (3.0 * (q1 - q0) / h - 2.0 * dq0 - dq1) / h
    c3 = (2.0 * (q0 - q1) / h + dq0 + dq1) / (h * h)
    return np.array([q0, dq0, c2, c3])


def drag_rate(p) -> float:
    """k = rho_air C_D pi r^2 / (2 m) [1/m] of the Params ``p``."""
    return 0.5 * p.rho_air * p.C_D * math.pi * p.r * p.r / p.m


def lift_rate(p) -> float:
    """k_L = rho_air pi r^2 / (2 m) [1/m] of the Params ``p`` (the Magnus lift's, ``physics.shot_air``)."""
    return 0.5 * p.rho_air * math.pi * p.r * p.r / p.m


class Flight:
    """The flight from ``position`` [m] with ``velocity`` [m/s] and ``spin`` [1/s] at its time 0 under the
    Params ``p``; ``lift``: with the Magnus lift (``physics.shot_air``; it needs rho_air > 0)."""

    def __init__(self, p, position, velocity, spin=(0.0, 0.0, 0.0), lift: bool = False):
        self.g, self.k, self.R, self.r = p.g, drag_rate(p), p.R, p.r
        self.k_lift = lift_rate(p) if lift else 0.0
        self.rho = p.r + p.a
        self.level = board_of(p.R, p.a).x - p.r
        self.p0, self.v0 = [float(c) for c in position], [float(c) for c in velocity]
        self.w = np.array([float(c) for c in spin])
        self.air = self.k > 0.0 or self.k_lift > 0.0
        if self.air:
            self.rows = np.empty((CHUNK, 7))
            self.rows[0] = (0.0, *self.p0, *self.v0)
            self.gates = np.zeros(CHUNK, np.int8)
            self.n = 1

    # ---- the table of steps (air)
    def _grow(self, t_until: float, z_stop: float = -math.inf) -> bool:
        """Add steps until one reaches ``t_until`` [s] or its z is below ``z_stop`` [m] descending; False
        when no step could be added (already there)."""
        n0 = self.n
        while True:
            if self.n == self.rows.shape[0]:
                self.rows = np.concatenate([self.rows, np.empty((CHUNK, 7))])
                self.gates = np.concatenate([self.gates, np.zeros(CHUNK, np.int8)])
            n = flight_steps(self.rows, self.gates, self.n, self.w, self.k, self.k_lift, self.r, self.g, DRAG_STEP,
                             t_until, z_stop, (self.R, self.rho, self.level))
            grew, self.n = n > self.n, n
            if n < self.rows.shape[0] or not grew:
                return self.n > n0

    def _extend(self, t: float) -> None:
        if self.n < 2 or self.rows[self.n - 1, 0] < t:
            self._grow(t)

    def _step_of(self, t: float) -> int:
        self._extend(t)
        return min(int(t / DRAG_STEP), self.n - 2)

    def _polys(self, i: int):
        a, b = self.rows[i], self.rows[i + 1]
        h = b[0] - a[0]
        return [hermite_coefficients(a[1 + c], a[4 + c], b[1 + c], b[4 + c], h) for c in range(3)]

    def position(self, t: float):
        """Centre position (x, y, z) [m] at time ``t`` [s]."""
        if not self.air:
            return tuple(self.p0[c] + self.v0[c] * t - (0.5 * self.g * t * t if c == 2 else 0.0) for c in range(3))
        i = self._step_of(t)
        return tuple(float(np.polynomial.polynomial.polyval(t - self.rows[i, 0], q)) for q in self._polys(i))

    def velocity(self, t: float):
        """Centre velocity [m/s] at time ``t`` [s]."""
        if not self.air:
            return tuple(self.v0[c] - (self.g * t if c == 2 else 0.0) for c in range(3))
        i = self._step_of(t)
        P = np.polynomial.polynomial
        return tuple(float(P.polyval(t - self.rows[i, 0], P.polyder(q))) for q in self._polys(i))

    def time_to_depth(self, z_level: float, t_limit: float = 1000.0) -> float:
        """Time [s] at which the centre, descending, passes below ``z_level`` [m] (inf past ``t_limit``)."""
        if not self.air:
            vz, dz = self.v0[2], self.p0[2] - z_level
            return (vz + math.sqrt(max(vz * vz + 2.0 * self.g * dz, 0.0))) / self.g
        rows = self.rows[:self.n]
        below = np.flatnonzero((rows[1:, 3] < z_level) & (rows[1:, 6] < 0.0))
        if not below.size:
            self._grow(t_limit, z_level)
            rows = self.rows[:self.n]
            below = np.flatnonzero((rows[1:, 3] < z_level) & (rows[1:, 6] < 0.0))
            if not below.size:
                return math.inf
        i = int(below[0])
        t0, t1 = rows[i, 0], rows[i + 1, 0]
        zs = np.polynomial.polynomial.polysub(self._polys(i)[2], [z_level])
        roots = [r.real for r in np.roots(zs[::-1]) if abs(r.imag) < 1e-12 and 0.0 <= r.real <= t1 - t0]
        return t0 + (max(roots) if roots else t1 - t0)

    def pieces(self, span: float):
        """(t0, t1, i, ring, plane) of the flight's polynomial pieces up to ``span`` [s] that the bound
        lets touch the ring (``ring``) or reach the board's plane (``plane``), in time order (i: the piece
        for :meth:`polynomials`). In vacuum: the one parabola, both flags True."""
        if not self.air:
            yield 0.0, span, -1, True, True
            return
        self._extend(span)
        last = min(self.n - 1, int(math.ceil(span / DRAG_STEP)) + 1)
        for i in np.flatnonzero(self.gates[:last]):
            i = int(i)
            t0 = self.rows[i, 0]
            if t0 >= span:
                return
            gate = int(self.gates[i])
            yield t0, min(self.rows[i + 1, 0], span), i, bool(gate & RING), bool(gate & PLANE)

    def polynomials(self, i: int):
        """The (x, y, z) polynomials (lowest first) in t - t0 of piece ``i``."""
        if i < 0:
            return ([self.p0[0], self.v0[0]], [self.p0[1], self.v0[1]], [self.p0[2], self.v0[2], -0.5 * self.g])
        return tuple(self._polys(i))

    def sample(self, path, t_offset: float, t_until: float, n: int) -> None:
        """Append ``n`` samples of the flight from 0 to ``t_until`` [s] (phase 0) to ``path``."""
        for t in np.linspace(0.0, t_until, max(int(n), 2)):
            x, y, z = self.position(float(t))
            path.time.append(t_offset + float(t))
            path.x.append(x)
            path.y.append(y)
            path.z.append(z)
            path.phase.append(0)


def drag_height_at(speed: float, angle: float, distance: float, height: float, k: float, g: float) -> float:
    """z [m] of the centre (released at (-distance, 0, -height) with ``speed`` at elevation ``angle``, drag
    rate ``k`` [1/m]) when it reaches x = 0 (the hoop's axis); -inf if it never does."""
    from rimroll.solver.physics.params import Params

    p = Params(rho_air=1.0, C_D=1.0)
    p = p.replace(rho_air=2.0 * k * p.m / (p.C_D * math.pi * p.r * p.r), g=g)
    flight = Flight(p, [-distance, 0.0, -height], [speed * math.cos(angle), 0.0, speed * math.sin(angle)])
    i = 0
    while True:
        flight._extend((i + 1) * DRAG_STEP)
        t0, t1 = flight.rows[i, 0], flight.rows[i + 1, 0]
        x1, vx1 = flight.rows[i + 1, 1], flight.rows[i + 1, 4]
        if x1 >= 0.0:
            xs = np.polynomial.polynomial.polysub(flight._polys(i)[0], [0.0])
            roots = [r.real for r in np.roots(xs[::-1]) if abs(r.imag) < 1e-9 and -1e-12 <= r.real <= t1 - t0 + 1e-12]
            return float(np.polynomial.polynomial.polyval(min(roots), flight._polys(i)[2]))
        if vx1 <= 0.0 or t1 > 100.0:
            return -math.inf
        i += 1
