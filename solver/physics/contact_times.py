"""The first time a ball on a polynomial path touches the ring or the board, found by root isolation.

The ball's centre follows x(t), y(t), z(t), polynomials in t (the vacuum parabola; or, with drag, the
cubic Hermite interpolant of one step). It touches the ring (torus of major radius R, ball-centre
distance rho = r + a from the centre circle) where d(t) = sqrt((sqrt(x^2 + y^2) - R)^2 + z^2) = rho.
Squared out, with s = x^2 + y^2 + z^2 and q = x^2 + y^2,

    F(t) = (s + R^2 - rho^2)^2 - 4 R^2 q = (d^2 - rho^2) ((sqrt(q) + R)^2 + z^2 - rho^2),

a polynomial (degree 8 for a parabola), whose sign is the sign of d - rho when R > rho (the second
factor is then > 0). Between two consecutive real roots of F' the polynomial F is monotone, so it has at
most one root there. The search therefore takes the real roots of F' in the interval (numpy's companion
eigenvalues, keeping near-real pairs too: an extra point is harmless, a missing one is not), evaluates
d - rho exactly at them in time order and stops at the first point where d <= rho: a tangential graze
(a double root of F) is a minimum of F and so one of these points; a crossing is bracketed between the
last point outside and this one and solved by Brent's method to round-off.
"""

from __future__ import annotations

import math

import numpy as np
from numpy.polynomial import polynomial as poly
from scipy.optimize import brentq

LEAVE_GRACE = 1e-3
"""[s] after leaving the ring, touches shallower than :data:`LEAVE_TOLERANCE` this early are the
separation itself (the gap then grows from 0 at third order or slower), not a new contact."""
LEAVE_TOLERANCE = 1e-12
"""[m] depth below which an early touch after leaving the ring counts (see :data:`LEAVE_GRACE`)."""

NEAR_REAL = 1e-5
"""Largest |imaginary part| (in units of the interval) of a root of F' kept as a candidate point."""


def horner(c, x: float) -> float:
    """The polynomial with coefficients ``c`` (lowest first) at ``x``."""
    result = 0.0
    for a in reversed(c):
        result = result * x + a
    return float(result)


def scaled(coefficients, span: float) -> np.ndarray:
    """Coefficients (lowest first) of p(span * tau) for p(t) with ``coefficients``."""
    c = np.asarray(coefficients, dtype=float)
    return c * span ** np.arange(c.size)


def _real_points(p: np.ndarray) -> list[float]:
    """The near-real roots in (0, 1) of the polynomial ``p`` (lowest first), sorted."""
    p = np.trim_zeros(p, "b")
    if p.size <= 1:
        return []
    top = np.max(np.abs(p))
    if top == 0.0:
        return []
    roots = np.roots((p / top)[::-1])
    return sorted(float(z.real) for z in roots if abs(z.imag) <= NEAR_REAL and 0.0 < z.real < 1.0)


def _plus(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Sum of two coefficient arrays (lowest first) of any lengths."""
    if a.size < b.size:
        a, b = b, a
    out = a.copy()
    out[:b.size] += b
    return out


def ring_function(xp, yp, zp, R: float, rho: float) -> np.ndarray:
    """Coefficients of F = (x^2 + y^2 + z^2 + R^2 - rho^2)^2 - 4 R^2 (x^2 + y^2) for the path polynomials."""
    xp, yp, zp = (np.asarray(c, dtype=float) for c in (xp, yp, zp))
    q = _plus(np.convolve(xp, xp), np.convolve(yp, yp))
    w = _plus(q, np.convolve(zp, zp))
    w[0] += R * R - rho * rho
    return _plus(np.convolve(w, w), -4.0 * R * R * q)


def first_ring_contact(xp, yp, zp, span: float, R: float, rho: float, leaving: bool) -> float:
    """First time t in [0, ``span``] [s] at which the centre on the path (polynomials in t, lowest
    first) is at the distance ``rho`` [m] from the ring's centre circle (radius ``R``), or NaN. With
    ``leaving`` (just after an impact on the ring or a separation from it, the ball moving away) the
    touch at t = 0 is not counted, nor one shallower than LEAVE_TOLERANCE within LEAVE_GRACE."""
    xs, ys, zs = scaled(xp, span), scaled(yp, span), scaled(zp, span)

    grace = LEAVE_GRACE / span if leaving else 0.0

    def gap(tau):
        g = math.hypot(math.hypot(horner(xs, tau), horner(ys, tau)) - R, horner(zs, tau)) - rho
        return g + LEAVE_TOLERANCE if tau < grace else g

    f = ring_function(xs, ys, zs, R, rho)
    points = [0.0, *_real_points(f[1:] * np.arange(1, f.size)), 1.0]
    previous, g_previous = 0.0, gap(0.0)
    if g_previous <= 0.0 and not leaving:
        return 0.0
    for tau in points[1:]:
        g = gap(tau)
        if g <= 0.0:
            if g_previous > 0.0:
                tau = brentq(gap, previous, tau, xtol=1e-16, rtol=1e-15)
            else:  # just left the ring and back at once (no rebound speed): touching again right away
                tau = previous
            return tau * span
        previous, g_previous = tau, g
    return math.nan


def first_plane_contact(xp, span: float, level: float) -> float:
    """First time t in [0, ``span``] [s] at which x(t) (polynomial, lowest first) reaches ``level`` [m]
    from below, or NaN; 0 if it is there already and still moving towards it."""
    xs = poly.polysub(scaled(xp, span), [level])
    if poly.polyval(0.0, xs) >= 0.0:
        return 0.0 if xs.size > 1 and xs[1] > 0.0 else math.nan
    if xs.size == 2:  # a straight line: x(tau) = level at -xs[0] / xs[1]
        tau = -xs[0] / xs[1] if xs[1] > 0.0 else math.inf
        return tau * span if tau <= 1.0 else math.nan
    candidates = [*_real_points(poly.polyder(xs)), 1.0]
    previous = 0.0
    for tau in sorted(candidates):
        if horner(xs, tau) >= 0.0:
            return brentq(lambda s: horner(xs, s), previous, tau, xtol=1e-16, rtol=1e-15) * span
        previous = tau
    return math.nan
