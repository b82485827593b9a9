"""Steady motions of the rolling ball and their limits (paper Sect. 3).

The closed forms (46)-(48) and h (54) are ``solver.physics.steady_motion`` (re-exported here:
``steady.omega20``, ``steady.stability``, ``steady.steady_state``, ``steady.trivial_state``); this
module adds what limits them: stability bands, the friction they need, falling, the throw speed
and the realisable regions A/B/C of Fig. 8.

Every function broadcasts over numpy arrays of beta0 [rad] and omega30 [1/s] and takes a
``Params`` (TypeError naming ``p`` otherwise). Points on the singular lines cos(beta0) = 0 or
omega30 = 0 give inf/NaN, never an exception, and so does a NaN or inf beta0 or omega30 (NaN in,
NaN out; a condition [bool] is False there and the region REGION_NONE, as a comparison with NaN
is). The scalar arguments are checked: ``mu`` (a number >= 0, inf allowed) and ``v_throw`` (a
number >= 0 [m/s], inf allowed) give a ValueError naming them when they are NaN, negative or not
a number.
"""

from __future__ import annotations

import numpy as np

from rimroll.solver._arguments import integer, nonnegative_number
from rimroll.solver._jit import vectorised
from rimroll.solver.physics import rolling
from rimroll.solver.physics.params import Params
from rimroll.solver.physics.steady_motion import check_params, omega20, stability, steady_state, trivial_state

# Region labels of Fig. 8 (CF flag_values / flag_meanings).
REGION_NONE, REGION_A, REGION_B, REGION_C = 0, 1, 2, 3
REGION_FLAG_VALUES = (REGION_NONE, REGION_A, REGION_B, REGION_C)
REGION_FLAG_MEANINGS = "not_realisable A_inside_above B_inside_below C_outside_above"

_contact_forces = vectorised(rolling.contact_forces)


def beta_star(p: Params) -> float:
    """beta* = arccos((1+j) rho / R) [rad]: the unstable band |beta0| < beta* as omega30 -> inf.

    Requires R > (1+j) rho; raises ValueError otherwise.
    """
    check_params(p)
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
    check_params(p)
    coeffs = [p.rho**2 * (1 + p.j), -p.R * p.rho, p.R**2, -p.R * p.rho * (1 + p.j)]
    roots = np.roots(coeffs)
    real = roots[(np.abs(roots.imag) < 1e-12) & (np.abs(roots.real) < 1)].real
    if real.size != 1:
        raise ValueError(f"(55) has {real.size} real roots in (-1, 1) for {p}; expected one")
    return float(np.arccos(real[0]))


def trivial_eigenvalue(p: Params) -> float:
    """The positive eigenvalue sqrt((g/rho)/(1+j)) [1/s] of the trivial steady motion x0+."""
    check_params(p)
    return float(np.sqrt(p.g / p.rho / (1 + p.j)))


def contact_forces(beta0, omega30, p: Params):
    """Contact forces (F1, F2, F3) [N] of the steady motion (47) at beta0 [rad], omega30 [1/s], from the
    rolling forces (30)-(32)."""
    x = steady_state(beta0, omega30, p)
    return _contact_forces(x[..., 0], x[..., 1], x[..., 2], x[..., 3], p.as_array())


def required_friction(beta0, omega30, p: Params):
    """Smallest friction coefficient [-] that keeps the steady motion at beta0 [rad], omega30 [1/s]
    rolling: |F_t| / F2.

    inf where F2 <= 0 (the ball falls whatever mu). The slip boundary (56) for a given mu is
    the level set ``required_friction == mu``; the fall boundary (57) is where it diverges.
    """
    F1, F2, F3 = contact_forces(beta0, omega30, p)
    tangential = np.hypot(F1, F3)
    with np.errstate(divide="ignore", invalid="ignore"):
        return np.where(F2 > 0, tangential / np.where(F2 > 0, F2, 1.0), np.inf)


def rolls_without_slipping(beta0, omega30, p: Params, mu: float | None = None):
    """Slip condition (56) [bool] of the steady motion at beta0 [rad], omega30 [1/s], at the friction
    coefficient mu [-] (a number >= 0, inf allowed; default p.mu); with mu = inf the fall condition (57).
    """
    check_params(p)
    mu = p.mu if mu is None else nonnegative_number("mu", mu, "a friction coefficient >= 0 (inf: never slips)")
    F1, F2, F3 = contact_forces(beta0, omega30, p)
    if np.isinf(mu):
        return F2 >= 0
    return mu * F2 >= np.hypot(F1, F3)


def stays_on_rim(beta0, omega30, p: Params):
    """Fall condition (57) [bool]: the normal force of the steady motion at beta0 [rad], omega30 [1/s]
    is non-negative."""
    return rolls_without_slipping(beta0, omega30, p, mu=np.inf)


def throw_speed(beta0, omega30, p: Params):
    """Throw speed [m/s] whose kinetic energy equals that of the steady motion at beta0 [rad],
    omega30 [1/s], from (59).

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
    """Physically realisable steady motions (Fig. 8) [bool] at beta0 [rad], omega30 [1/s].

    Stable (h < 0), rolling without slipping at the friction coefficient mu [-] (default p.mu) (56),
    and needing no more kinetic energy than a throw at v_throw [m/s] (59). v_throw: a number
    >= 0 (inf: no energy limit); mu: a number >= 0 (inf: never slips). ValueError naming them
    otherwise (NaN, negative, not a number).
    """
    nonnegative_number("v_throw", v_throw, "a throw speed >= 0 [m/s] (inf: no energy limit)")
    with np.errstate(invalid="ignore"):
        return (
            (stability(beta0, omega30, p) < 0)
            & rolls_without_slipping(beta0, omega30, p, mu)
            & (throw_speed(beta0, omega30, p) <= v_throw)
        )


def realisable_region(beta0, omega30, p: Params, v_throw: float, mu: float | None = None):
    """Region code (int8) of each steady motion at beta0 [rad], omega30 [1/s]: REGION_A/B/C where it is
    realisable at the throw speed v_throw [m/s] and friction coefficient mu [-] (``realisable``),
    REGION_NONE elsewhere (and where beta0 or omega30 is NaN). Shape broadcast(beta0, omega30)."""
    beta0, omega30 = np.broadcast_arrays(np.asarray(beta0, float), np.asarray(omega30, float))
    ok = realisable(beta0, omega30, p, v_throw, mu)
    return np.where(ok, region_of(beta0), REGION_NONE).astype(np.int8)


def minimal_throw_speed(region: int, p: Params, mu: float | None = None, n: int = 801) -> float:
    """Smallest throw speed [m/s] at which the given region of Fig. 8 contains a realisable motion.

    The minimum of (59) over the stable, non-slipping steady motions of the region, found on a
    grid of n x n points and refined twice on grids zoomed around the best point. inf if the
    region holds no stable, non-slipping motion. region: REGION_A, REGION_B or REGION_C; mu [-]
    as in ``rolls_without_slipping``; n: an integer >= 3.
    """
    check_params(p)
    if (isinstance(region, bool) or not isinstance(region, (int, np.integer))
            or region not in (REGION_A, REGION_B, REGION_C)):
        raise ValueError(f"`region` must be REGION_A ({REGION_A}), REGION_B ({REGION_B}) or REGION_C ({REGION_C}); "
                         f"got {region!r}")
    n = integer("n", n, minimum=3)
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


__all__ = ["omega20", "stability", "steady_state", "trivial_state", "beta_star", "beta_hat",
           "trivial_eigenvalue", "contact_forces", "required_friction", "rolls_without_slipping", "stays_on_rim",
           "throw_speed", "region_of", "realisable", "realisable_region", "minimal_throw_speed"]
