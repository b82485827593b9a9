"""The flight of the ball's centre between impacts: the vacuum parabola, or the flight with air drag.

In vacuum the centre follows p(t) = p0 + v0 t - (0, 0, g t^2 / 2), one polynomial piece. With drag
(rho_air > 0, k = rho_air C_D pi r^2 / (2 m), acceleration -g z - k |v| v as ``physics.flight``) the
flight is integrated by classical Runge-Kutta steps of :data:`DRAG_STEP` and each step is the cubic
Hermite polynomial through its end positions and velocities; a step is searched for a ring contact
only if a bound allows one (:meth:`Flight.may_touch_ring`). The spin does not change in flight (no
aerodynamic torque); the Magnus force is not modelled.
"""

from __future__ import annotations

import math

import numpy as np

DRAG_STEP = 2e-3
"""[s] step of the flight with drag (Runge-Kutta 4: position error ~1e-11 m over a shot)."""


def _acceleration(v, k: float, g: float):
    c = -k * math.sqrt(v[0] * v[0] + v[1] * v[1] + v[2] * v[2])
    return (c * v[0], c * v[1], c * v[2] - g)


def _rk4(p, v, h: float, k: float, g: float):
    """One classical Runge-Kutta step of length h [s] of the flight with drag: new position, velocity."""
    a1 = _acceleration(v, k, g)
    v2 = [v[i] + 0.5 * h * a1[i] for i in range(3)]
    a2 = _acceleration(v2, k, g)
    v3 = [v[i] + 0.5 * h * a2[i] for i in range(3)]
    a3 = _acceleration(v3, k, g)
    v4 = [v[i] + h * a3[i] for i in range(3)]
    a4 = _acceleration(v4, k, g)
    s = h / 6.0
    return ([p[i] + s * (v[i] + 2.0 * v2[i] + 2.0 * v3[i] + v4[i]) for i in range(3)],
            [v[i] + s * (a1[i] + 2.0 * a2[i] + 2.0 * a3[i] + a4[i]) for i in range(3)])


def hermite_coefficients(q0: float, dq0: float, q1: float, dq1: float, h: float) -> np.ndarray:
    """Coefficients (lowest first, in t from 0 to h [s]) of the cubic with values q0, q1 and slopes dq0, dq1."""
    c2 = (3.0 * (q1 - q0) / h - 2.0 * dq0 - dq1) / h
    c3 = (2.0 * (q0 - q1) / h + dq0 + dq1) / (h * h)
    return np.array([q0, dq0, c2, c3])


def drag_rate(p) -> float:
    """k = rho_air C_D pi r^2 / (2 m) [1/m] of the Params ``p``."""
    return 0.5 * p.rho_air * p.C_D * math.pi * p.r * p.r / p.m


class Flight:
    """The flight from ``position`` [m] with ``velocity`` [m/s] at its time 0 under the Params ``p``."""

    def __init__(self, p, position, velocity):
        self.g, self.k, self.R = p.g, drag_rate(p), p.R
        self.p0, self.v0 = list(position), list(velocity)
        self.steps = [(0.0, self.p0, self.v0)]  # drag: (time, position, velocity) at the step ends

    # ---- vacuum / drag switch
    def _extend(self, t: float) -> None:
        while len(self.steps) < 2 or self.steps[-1][0] < t:
            t0, p, v = self.steps[-1]
            p1, v1 = _rk4(p, v, DRAG_STEP, self.k, self.g)
            self.steps.append((t0 + DRAG_STEP, p1, v1))

    def _step_of(self, t: float) -> int:
        self._extend(t)
        return min(int(t / DRAG_STEP), len(self.steps) - 2)

    def _polys(self, i: int):
        t0, p, v = self.steps[i]
        t1, p1, v1 = self.steps[i + 1]
        return [hermite_coefficients(p[c], v[c], p1[c], v1[c], t1 - t0) for c in range(3)]

    def position(self, t: float):
        """Centre position (x, y, z) [m] at time ``t`` [s]."""
        if self.k == 0.0:
            return tuple(self.p0[c] + self.v0[c] * t - (0.5 * self.g * t * t if c == 2 else 0.0) for c in range(3))
        i = self._step_of(t)
        return tuple(float(np.polynomial.polynomial.polyval(t - self.steps[i][0], q)) for q in self._polys(i))

    def velocity(self, t: float):
        """Centre velocity [m/s] at time ``t`` [s]."""
        if self.k == 0.0:
            return tuple(self.v0[c] - (self.g * t if c == 2 else 0.0) for c in range(3))
        i = self._step_of(t)
        P = np.polynomial.polynomial
        return tuple(float(P.polyval(t - self.steps[i][0], P.polyder(q))) for q in self._polys(i))

    def time_to_depth(self, z_level: float, t_limit: float = 1000.0) -> float:
        """Time [s] at which the centre, descending, passes below ``z_level`` [m] (inf past ``t_limit``)."""
        if self.k == 0.0:
            vz, dz = self.v0[2], self.p0[2] - z_level
            return (vz + math.sqrt(max(vz * vz + 2.0 * self.g * dz, 0.0))) / self.g
        i = 0
        while True:
            self._extend((i + 1) * DRAG_STEP)
            t0, p, v = self.steps[i]
            t1, p1, v1 = self.steps[i + 1]
            if p1[2] < z_level and v1[2] < 0.0:
                zs = np.polynomial.polynomial.polysub(self._polys(i)[2], [z_level])
                roots = [r.real for r in np.roots(zs[::-1]) if abs(r.imag) < 1e-12 and 0.0 <= r.real <= t1 - t0]
                return t0 + (max(roots) if roots else t1 - t0)
            if t1 > t_limit:
                return math.inf
            i += 1

    def pieces(self, span: float):
        """(t0, t1, i) of the flight's polynomial pieces up to ``span`` [s], in time order (i: the piece
        for :meth:`polynomials`, :meth:`may_touch_ring`, :meth:`may_reach_plane`)."""
        if self.k == 0.0:
            yield 0.0, span, -1
            return
        self._extend(span)
        for i in range(len(self.steps) - 1):
            t0, t1 = self.steps[i][0], min(self.steps[i + 1][0], span)
            if t0 >= span:
                return
            yield t0, t1, i

    def polynomials(self, i: int):
        """The (x, y, z) polynomials (lowest first) in t - t0 of piece ``i``."""
        if i < 0:
            return ([self.p0[0], self.v0[0]], [self.p0[1], self.v0[1]], [self.p0[2], self.v0[2], -0.5 * self.g])
        return tuple(self._polys(i))

    def _bound(self, i: int):
        """Ends of step ``i`` and the bound 1.1 (largest end speed + g h) h on the path length over it."""
        t0, a, va = self.steps[i]
        t1, b, vb = self.steps[i + 1]
        s = max(math.hypot(*va), math.hypot(*vb)) + self.g * (t1 - t0)
        return a, b, 1.1 * s * (t1 - t0)

    def may_touch_ring(self, i: int, rho: float) -> bool:
        """Whether the centre can come within ``rho`` [m] of the ring's centre circle on piece ``i``: the
        distance d is Lipschitz with the speed, so on a step of path length at most L its least value is
        at least (d(t0) + d(t1) - L) / 2 (the step's whole length bounds any part of it too)."""
        if i < 0:
            return True
        a, b, length = self._bound(i)
        d0 = math.hypot(math.hypot(a[0], a[1]) - self.R, a[2])
        d1 = math.hypot(math.hypot(b[0], b[1]) - self.R, b[2])
        return 0.5 * (d0 + d1 - length) <= rho

    def may_reach_plane(self, i: int, level: float) -> bool:
        """Whether x can reach ``level`` [m] on piece ``i`` (bounded as in :meth:`may_touch_ring`)."""
        if i < 0:
            return True
        a, b, length = self._bound(i)
        return 0.5 * (a[0] + b[0] + length) >= level

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
        t0, (t1, p1, v1) = flight.steps[i][0], flight.steps[i + 1]
        if p1[0] >= 0.0:
            xs = np.polynomial.polynomial.polysub(flight._polys(i)[0], [0.0])
            roots = [r.real for r in np.roots(xs[::-1]) if abs(r.imag) < 1e-9 and -1e-12 <= r.real <= t1 - t0 + 1e-12]
            return float(np.polynomial.polynomial.polyval(min(roots), flight._polys(i)[2]))
        if v1[0] <= 0.0 or t1 > 100.0:
            return -math.inf
        i += 1
