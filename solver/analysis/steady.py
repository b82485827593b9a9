"""Steady motions of the rolling ball and their limits (paper Sect. 3).

A non-trivial steady motion (47) is fixed by the height angle beta0 [rad] and the circular
angular velocity omega30 [1/s]; (48) gives the orthogonal angular velocity omega20 [1/s] it
needs. Every function broadcasts over numpy arrays of beta0 and omega30 and takes a
:class:`solver.Params`. Points on the singular lines cos(beta0) = 0 or omega30 = 0 give
inf/NaN, never an exception.
"""

from __future__ import annotations

import numpy as np

from rimroll.solver.physics import rolling
from rimroll.solver._jit import vectorised
from rimroll.solver.physics.params import Params

# Region labels of Fig. 8 (CF flag_values / flag_meanings).
REGION_NONE, REGION_A, REGION_B, REGION_C = 0, 1, 2, 3
REGION_FLAG_VALUES = (REGION_NONE, REGION_A, REGION_B, REGION_C)
REGION_FLAG_MEANINGS = "not_realisable A_inside_above B_inside_below C_outside_above"

_contact_forces = vectorised(rolling.contact_forces)


def omega20(beta0, omega30, p: Params):
    """Orthogonal angular velocity (48) of the non-trivial steady motion [1/s]."""
    beta0 = np.asarray(beta0, dtype=float)
    omega30 = np.asarray(omega30, dtype=float)
    with np.errstate(divide="ignore", invalid="ignore"):
        return (1 + p.j) * omega30 * np.sin(beta0) / (p.j * np.cos(beta0)) - p.g * (
            p.R - p.rho * np.cos(beta0)
        ) / (p.j * p.r**2 * omega30)


def steady_state(beta0, omega30, p: Params):
    """The rolling state (beta0, 0, omega20, omega30) of (47), shape broadcast(beta0, omega30) + (4,)."""
    beta0, omega30 = np.broadcast_arrays(np.asarray(beta0, float), np.asarray(omega30, float))
    return np.stack([beta0, np.zeros_like(beta0), omega20(beta0, omega30, p), omega30], axis=-1)


def trivial_state(sign: int, omega20_value, p: Params):
    """Trivial steady motion x0+ (sign=+1, ball on top) or x0- (sign=-1, hanging) of (46)."""
    w2 = np.asarray(omega20_value, float)
    beta = np.full_like(w2, np.pi / 2 * np.sign(sign))
    zero = np.zeros_like(w2)
    return np.stack([beta, zero, w2, zero], axis=-1)


def stability(beta0, omega30, p: Params):
    """h(beta0, omega30) of (54) [1/s^2]: the squared non-zero eigenvalues of the linearisation.

    h < 0: a neutrally stable centre (eigenvalues +-i sqrt(-h)); h > 0: a saddle (+-sqrt(h)).
    """
    beta0 = np.asarray(beta0, dtype=float)
    omega30 = np.asarray(omega30, dtype=float)
    r, R, rho, j, g = p.r, p.R, p.rho, p.j, p.g
    c = np.cos(beta0)
    s = np.sin(beta0)
    D = R - rho * c
    with np.errstate(divide="ignore", invalid="ignore"):
        return (
            omega30**2 * r**2 * (R * c - (1 + j) * rho) / ((1 + j) * rho * D**2)
            - 2 * g * s * c / ((1 + j) * D)
            + g**2 * c * D / (r**2 * rho * (1 + j) ** 2 * omega30**2)
        )


def beta_star(p: Params) -> float:
    """beta* = arccos((1+j) rho / R) [rad]: the unstable band |beta0| < beta* as omega30 -> inf.

    Requires R > (1+j) rho; raises ValueError otherwise.
    """
    ratio = (1 + p.j) * p.rho / p.R
    if ratio >= 1:
        raise ValueError(f"beta_star needs R > (1+j) rho; here (1+j) rho / R = {ratio:.4g}")
    return float(np.arccos(ratio))


def beta_hat(p: Params) -> float:
    """beta_hat = min |beta0| of the stable region [rad]: arccos of the root in (-1, 1) of (55).

    No steady motion with |beta0| < beta_hat is stable, whatever omega30; the stable region comes
    closest to beta0 = 0 at |beta0| = beta_hat, at a finite omega30 (the black dots of Fig. 5),
    and its edge tends to |beta0| = beta* > beta_hat as omega30 -> inf.
    """
    coeffs = [p.rho**2 * (1 + p.j), -p.R * p.rho, p.R**2, -p.R * p.rho * (1 + p.j)]
    roots = np.roots(coeffs)
    real = roots[(np.abs(roots.imag) < 1e-12) & (np.abs(roots.real) < 1)].real
    if real.size != 1:
        raise ValueError(f"(55) has {real.size} real roots in (-1, 1) for {p}; expected one")
    return float(np.arccos(real[0]))


def trivial_eigenvalue(p: Params) -> float:
    """The positive eigenvalue sqrt((g/rho)/(1+j)) [1/s] of the trivial steady motion x0+."""
    return float(np.sqrt(p.g / p.rho / (1 + p.j)))


def contact_forces(beta0, omega30, p: Params):
    """Contact forces (F1, F2, F3) [N] of the steady motion (47), from the rolling forces (30)-(32)."""
    x = steady_state(beta0, omega30, p)
    return _contact_forces(x[..., 0], x[..., 1], x[..., 2], x[..., 3], p.as_array())


def required_friction(beta0, omega30, p: Params):
    """Smallest friction coefficient that keeps the steady motion rolling, |F_t| / F2 [-].

    inf where F2 <= 0 (the ball falls whatever mu). The slip boundary (56) for a given mu is
    the level set ``required_friction == mu``; the fall boundary (57) is where it diverges.
    """
    F1, F2, F3 = contact_forces(beta0, omega30, p)
    tangential = np.hypot(F1, F3)
    with np.errstate(divide="ignore", invalid="ignore"):
        return np.where(F2 > 0, tangential / np.where(F2 > 0, F2, 1.0), np.inf)


def rolls_without_slipping(beta0, omega30, p: Params, mu: float | None = None):
    """Slip condition (56) at friction mu (default p.mu) [bool]; with mu = inf the fall condition (57)."""
    mu = p.mu if mu is None else float(mu)
    F1, F2, F3 = contact_forces(beta0, omega30, p)
    if np.isinf(mu):
        return F2 >= 0
    return mu * F2 >= np.hypot(F1, F3)


def stays_on_rim(beta0, omega30, p: Params):
    """Fall condition (57): the normal force of the steady motion is non-negative [bool]."""
    return rolls_without_slipping(beta0, omega30, p, mu=np.inf)


def throw_speed(beta0, omega30, p: Params):
    """Throw speed whose kinetic energy equals that of the steady motion, from (59) [m/s].

    v = sqrt(j r^2 omega20^2 + (1+j) r^2 omega30^2).
    """
    w2 = omega20(beta0, omega30, p)
    w3 = np.asarray(omega30, float)
    return np.sqrt(p.j * p.r**2 * w2**2 + (1 + p.j) * p.r**2 * w3**2)


def region_of(beta0):
    """Region letter code of Fig. 8 by position on the rim: A (0, pi/2), B (-pi/2, 0), C (pi/2, pi).

    Returns REGION_A / REGION_B / REGION_C, REGION_NONE elsewhere (angles are wrapped to [-pi, pi)).
    """
    b = (np.asarray(beta0, float) + np.pi) % (2 * np.pi) - np.pi
    out = np.full(b.shape, REGION_NONE, dtype=np.int8)
    out[(b > 0) & (b < np.pi / 2)] = REGION_A
    out[(b > -np.pi / 2) & (b < 0)] = REGION_B
    out[(b > np.pi / 2) & (b < np.pi)] = REGION_C
    return out


def realisable(beta0, omega30, p: Params, v_throw: float, mu: float | None = None):
    """Physically realisable steady motions (Fig. 8) [bool].

    Stable (h < 0), rolling without slipping at friction mu (default p.mu) (56), and needing no
    more kinetic energy than a throw at v_throw [m/s] (59).
    """
    with np.errstate(invalid="ignore"):
        return (
            (stability(beta0, omega30, p) < 0)
            & rolls_without_slipping(beta0, omega30, p, mu)
            & (throw_speed(beta0, omega30, p) <= v_throw)
        )


def realisable_region(beta0, omega30, p: Params, v_throw: float, mu: float | None = None):
    """Region code (REGION_A/B/C) of each realisable steady motion, REGION_NONE elsewhere (int8)."""
    beta0, omega30 = np.broadcast_arrays(np.asarray(beta0, float), np.asarray(omega30, float))
    ok = realisable(beta0, omega30, p, v_throw, mu)
    return np.where(ok, region_of(beta0), REGION_NONE).astype(np.int8)


def minimal_throw_speed(region: int, p: Params, mu: float | None = None, n: int = 801) -> float:
    """Smallest throw speed [m/s] at which the given region of Fig. 8 contains a realisable motion.

    The minimum of (59) over the stable, non-slipping steady motions of the region, found on a
    grid of n x n points and refined twice on grids zoomed around the best point. inf if the
    region holds no stable, non-slipping motion.
    """
    lo, hi = {REGION_A: (0.0, np.pi / 2), REGION_B: (-np.pi / 2, 0.0), REGION_C: (np.pi / 2, np.pi)}[region]
    b_lo, b_hi, w_lo, w_hi = lo, hi, 1e-3, 200.0
    best = np.inf
    for _ in range(3):
        b = np.linspace(b_lo, b_hi, n)[1:-1]
        w = np.geomspace(w_lo, w_hi, n)
        B, W = np.meshgrid(b, w, indexing="ij")
        ok = (stability(B, W, p) < 0) & rolls_without_slipping(B, W, p, mu)
        v = np.where(ok, throw_speed(B, W, p), np.inf)
        k = np.unravel_index(np.argmin(v), v.shape)
        if not np.isfinite(v[k]):
            return float(best)
        best = min(best, float(v[k]))
        i, jw = k
        b_lo, b_hi = b[max(i - 3, 0)], b[min(i + 3, b.size - 1)]
        w_lo, w_hi = w[max(jw - 3, 0)], w[min(jw + 3, w.size - 1)]
    return best
