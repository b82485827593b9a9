"""Floquet analysis of the linear periodic systems (62) and (66) (paper Sect. 4.3, Prop. 7, Fig. 9).

With beta as independent variable (beta_dot = (r/rho) omega1 != 0), the rolling equations
(34)-(35) divided by (36) give the linear, 2 pi-periodic system (62) for z = (omega2, omega3):

    dz/dbeta = A(beta) z,   A = [[0,         R/(R - rho cos beta)],
                                 [-j/(1+j), -rho sin beta/(R - rho cos beta)]].

The coefficients c = (c2, c3) of a conserved quantity P = c2 omega2 + c3 omega3 (65) obey (66),

    dc/dbeta = -A(beta)^T c,  i.e.  c2' = j/(1+j) c3,
                                     c3' = -R/(R - rho cos beta) c2 + rho sin beta/(R - rho cos beta) c3,

the adjoint of (62): d/dbeta (c . z) = c'.z + c.Az = 0. Both (62) and (66) are checked against
``solver.rolling.rolling_rhs`` in the tests and are right as printed. Both depend on rho and R
only through x = rho/R (R/(R - rho cos) = 1/(1 - x cos), rho sin/(R - rho cos) = x sin/(1 - x cos))
and on j only through k = j/(1+j).

det M = 1 (Liouville). tr A(beta) = -rho sin beta/(R - rho cos beta) = -d/dbeta ln(R - rho cos beta),
so det Phi(beta) = exp(int_0^beta tr A) = (R - rho)/(R - rho cos beta) =: delta(beta) for the
fundamental matrix Phi of (62) with Phi(0) = I, and 1/delta(beta) for (66) (tr(-A^T) = -tr A).
Over a period the integral of tr A vanishes (ln(R - rho cos) is 2 pi-periodic), hence det M = 1 for
both systems, the multipliers satisfy mu1 mu2 = 1 and follow from tr M alone. Since the monodromy
matrix of (66) is M^{-T}, both systems have the same multipliers.

Reversibility. A(-beta) = -S A(beta) S with S = diag(1, -1) (the 12 and 21 entries are even, the 22
entry odd), so Phi(-beta) = S Phi(beta) S, and with Phi(beta + 2 pi) = Phi(beta) M,

    M = S Phi(pi)^{-1} S Phi(pi) = [[ad + bc, 2bd], [2ac, ad + bc]] / delta(pi),
    Phi(pi) = [[a, b], [c, d]],  delta(pi) = (1 - x)/(1 + x)  (for (66): (1 + x)/(1 - x)),

so only the half period [0, pi] is integrated, and tr M = 2 (ad + bc)/delta(pi).

Numerics. The coefficients are sharply peaked at beta = 0 when x -> 1 (width ~ sqrt(2(1 - x))).
The substitution tan(beta/2) = lam tan(theta/2), lam = ((1 - x)/(1 + x))^(1/4) (an eccentric-anomaly
type map, theta in [0, pi] <-> beta in [0, pi]) spreads that peak out: in theta the system matrix is

    dbeta/dtheta * A = [[0, 2 lam/n], [-k lam/q, -2 x lam^2 sin(theta)/(n q)]]            (62)
    q = ((1 + lam^2) + (1 - lam^2) cos theta)/2,
    n = (1 + lam^2) - x (1 - lam^2) + ((1 - lam^2) - x (1 + lam^2)) cos theta,

and the max/min ratio of the coefficients drops from (1+x)/(1-x) to its square root. The 2x2
fundamental matrix is then integrated with the 12-stage, 8th-order Runge-Kutta tableau of DOP853
at a fixed number of steps N (chosen from max x, >= 32), vectorised with numpy over the whole
parameter grid. Relative error of tr M against scipy DOP853 at rtol 1e-13: ~1e-13 for
x <= 0.99 (see tests/solver/analysis/test_floquet.py).
"""

from __future__ import annotations

import numpy as np

from rimroll.solver.engine.tableaus import _A853, _DOP853_C

_SYSTEMS = ("motion", "coefficients")
# DOP853 (Hairer's coefficients as scipy ships them, solver.engine.tableaus): 12 stages, weights = row 12.
# Read from solver.engine.tableaus, not scipy.integrate, whose import costs ~0.5 s of every `import solver`.
_A = _A853[:12, :12]
_B = _A853[12, :12]
_C = np.array(_DOP853_C[:12])


# --------------------------------------------------------------------------------------------
# input handling
# --------------------------------------------------------------------------------------------
def _check(rho_over_R, j, system="motion"):
    x = np.asarray(rho_over_R, dtype=float)
    jj = np.asarray(j, dtype=float)
    if not np.all((x > 0) & (x < 1)):
        bad = x[~((x > 0) & (x < 1))].ravel()[0]
        raise ValueError(f"rho_over_R={bad!r} is out of range: allowed 0 < rho_over_R < 1")
    if not np.all((jj > 0) & np.isfinite(jj)):
        bad = jj[~((jj > 0) & np.isfinite(jj))].ravel()[0]
        raise ValueError(f"j={bad!r} is out of range: allowed 0 < j < inf")
    if system not in _SYSTEMS:
        raise ValueError(f"system={system!r} is not one of {_SYSTEMS}")
    return x, jj


def _n_steps(x) -> int:
    """Fixed RK8 step count over theta in [0, pi] giving tr M to ~1e-12 relative or better."""
    xmax = float(np.max(x)) if np.size(x) else 0.5
    ratio = ((1.0 + xmax) / (1.0 - xmax)) ** 0.25
    return int(max(32, 16 * np.ceil(ratio)))


# --------------------------------------------------------------------------------------------
# system matrices
# --------------------------------------------------------------------------------------------
def system_matrix(beta, rho_over_R, j, system="motion"):
    """The matrix of (62) (``system="motion"``) or of (66) (``"coefficients"``) at beta, (..., 2, 2).

    beta [rad]; rho_over_R [-] may be any value in (0, inf] here, so that the limit R -> 0
    (rho_over_R -> inf, Prop. 12) can be studied: for x = rho/R > 1 the coefficients are written
    with y = R/rho as R/(R - rho cos) = y/(y - cos), rho sin/(R - rho cos) = sin/(y - cos)
    (singular where cos beta = y: the ball's centre would cross the rim's axis). No range check.
    """
    beta = np.asarray(beta, dtype=float)
    x = np.asarray(rho_over_R, dtype=float)
    k = np.asarray(j, dtype=float) / (1.0 + np.asarray(j, dtype=float))
    c, s = np.cos(beta), np.sin(beta)
    with np.errstate(divide="ignore", invalid="ignore"):
        y = np.where(x > 1, 1.0 / x, 1.0)
        xs = np.where(x > 1, 1.0, x)
        e = y / (y - xs * c)  # R/(R - rho cos beta)
        o = xs * s / (y - xs * c)  # rho sin beta/(R - rho cos beta)
    e, o, k = np.broadcast_arrays(e, o, k)
    out = np.zeros(e.shape + (2, 2))
    if system == "motion":
        out[..., 0, 1] = e
        out[..., 1, 0] = -k
        out[..., 1, 1] = -o
    elif system == "coefficients":
        out[..., 0, 1] = k
        out[..., 1, 0] = -e
        out[..., 1, 1] = o
    else:
        raise ValueError(f"system={system!r} is not one of {_SYSTEMS}")
    return out


def _theta_coefficients(theta, x, k, lam, system):
    """Entries (a12, a21, a22) of dbeta/dtheta * A(beta(theta)) (module docstring)."""
    ct = np.cos(theta)
    l2 = lam * lam
    q = 0.5 * ((1.0 + l2) + (1.0 - l2) * ct)
    n = (1.0 + l2) - x * (1.0 - l2) + ((1.0 - l2) - x * (1.0 + l2)) * ct
    e = 2.0 * lam / n
    kk = k * lam / q
    o = 2.0 * x * l2 * np.sin(theta) / (n * q)
    if system == "motion":
        return e, -kk, -o
    return kk, -e, o


def _theta_of_beta(beta, lam):
    """Inverse of tan(beta/2) = lam tan(theta/2) for beta in [0, pi]."""
    return 2.0 * np.arctan2(np.sin(beta / 2.0), lam * np.cos(beta / 2.0))


def _half_fundamental(theta_end, x, k, system, n_steps):
    """Phi at theta_end in [0, pi] (Phi(0) = I), fixed-step RK8, as 4 arrays (a, b, c, d)."""
    lam = ((1.0 - x) / (1.0 + x)) ** 0.25
    shape = np.broadcast_shapes(np.shape(theta_end), np.shape(x), np.shape(k))
    # state: entries (11, 12, 21, 22) stacked on the first axis
    P = np.zeros((4,) + shape)
    P[0] = 1.0
    P[3] = 1.0
    h = np.broadcast_to(np.asarray(theta_end, dtype=float) / n_steps, shape)
    K = np.empty((12, 4) + shape)
    for i in range(n_steps):
        t0 = i * h
        for s in range(12):
            if s:
                Y = P + h * np.tensordot(_A[s, :s], K[:s], axes=(0, 0))
            else:
                Y = P
            a12, a21, a22 = _theta_coefficients(t0 + _C[s] * h, x, k, lam, system)
            K[s, 0] = a12 * Y[2]
            K[s, 1] = a12 * Y[3]
            K[s, 2] = a21 * Y[0] + a22 * Y[2]
            K[s, 3] = a21 * Y[1] + a22 * Y[3]
        P = P + h * np.tensordot(_B, K, axes=(0, 0))
    return P


def _det_half(x, system):
    """det Phi(pi) = delta(pi) = (1 - x)/(1 + x) for (62); its inverse for (66)."""
    d = (1.0 - x) / (1.0 + x)
    return d if system == "motion" else 1.0 / d


# --------------------------------------------------------------------------------------------
# public API
# --------------------------------------------------------------------------------------------
def monodromy(rho_over_R, j, system="motion"):
    """Monodromy matrix M (Phi(2 pi), Phi(0) = I) of (62) or (66): real array (..., 2, 2).

    rho_over_R = rho/R [-] in (0, 1), j [-] > 0: numpy arrays, broadcast together.
    ``system="motion"``: z = (omega2, omega3) of (62); ``system="coefficients"``: c = (c2, c3)
    of (66), whose monodromy matrix is M^{-T}. det M = 1 analytically (module docstring); the
    computed det is a check of the integration.
    """
    x, jj = _check(rho_over_R, j, system)
    k = jj / (1.0 + jj)
    a, b, c, d = _half_fundamental(np.pi, x, k, system, _n_steps(x))
    delta = _det_half(x, system)
    diag = (a * d + b * c) / delta
    out = np.empty(diag.shape + (2, 2))
    out[..., 0, 0] = diag
    out[..., 1, 1] = diag
    out[..., 0, 1] = 2.0 * b * d / delta
    out[..., 1, 0] = 2.0 * a * c / delta
    return out


def trace(rho_over_R, j):
    """tr M of (62) (= tr of the monodromy matrix of (66)), broadcasting [-]."""
    x, jj = _check(rho_over_R, j)
    a, b, c, d = _half_fundamental(np.pi, x, jj / (1.0 + jj), "motion", _n_steps(x))
    return 2.0 * (a * d + b * c) / _det_half(x, "motion")


def multipliers_from_trace(tr):
    """Floquet multipliers (mu1, mu2), complex (..., 2), |mu1| <= |mu2|, of a 2x2 M with det M = 1.

    |tr| <= 2: mu = (tr -+ i sqrt(4 - tr^2))/2 on the unit circle (mu1 has Im <= 0).
    |tr| > 2: mu2 = sign(tr) (|tr| + sqrt(tr^2 - 4))/2, mu1 = 1/mu2 (no cancellation).
    """
    tr = np.asarray(tr, dtype=float)
    out = np.empty(tr.shape + (2,), dtype=complex)
    inside = np.abs(tr) <= 2.0
    with np.errstate(invalid="ignore", divide="ignore"):
        im = np.sqrt(np.where(inside, 4.0 - tr * tr, 0.0)) / 2.0
        big = np.sign(tr) * (np.abs(tr) + np.sqrt(np.where(inside, 0.0, tr * tr - 4.0))) / 2.0
        out[..., 0] = np.where(inside, tr / 2.0 - 1j * im, 1.0 / big)
        out[..., 1] = np.where(inside, tr / 2.0 + 1j * im, big)
    return out


def multipliers(rho_over_R, j):
    """Floquet multipliers of (62) over beta in [0, 2 pi]: complex (..., 2), |mu1| <= |mu2|.

    |mu1| = |mu2| = 1: neutrally stable, quasi-periodic (omega2, omega3) (Prop. 7, region S of
    Fig. 9); otherwise |mu1| < 1 < |mu2| and mu1 mu2 = 1 (region U). Computed from tr M alone
    (det M = 1 exactly).
    """
    return multipliers_from_trace(trace(rho_over_R, j))


def is_stable(rho_over_R, j):
    """True where |tr M| <= 2, i.e. both multipliers on the unit circle (Prop. 7), broadcasting."""
    return np.abs(trace(rho_over_R, j)) <= 2.0


def fundamental(beta, rho_over_R, j, system="motion"):
    """Fundamental matrix Phi(beta) of (62) or (66) with Phi(0) = I, at any real beta: (..., 2, 2).

    beta [rad], rho_over_R in (0, 1) and j > 0 broadcast together. beta is reduced to
    beta0 in [-pi, pi] with beta = beta0 + 2 pi m; then Phi(beta0) = S Phi(|beta0|) S
    (reversibility) is integrated from 0 to |beta0| (fixed-step RK8 in theta, ~1e-13 relative),
    and Phi(beta) = Phi(beta0) M^m (Floquet).
    """
    x, jj = _check(rho_over_R, j, system)
    beta = np.asarray(beta, dtype=float)
    if not np.all(np.isfinite(beta)):
        raise ValueError("beta must be finite")
    k = jj / (1.0 + jj)
    m = np.round(beta / (2.0 * np.pi))
    b0 = beta - 2.0 * np.pi * m
    lam = ((1.0 - x) / (1.0 + x)) ** 0.25
    theta_end = _theta_of_beta(np.abs(b0), lam)
    a, b, c, d = _half_fundamental(theta_end, x, k, system, _n_steps(x))
    sgn = np.where(b0 < 0, -1.0, 1.0)
    phi = np.empty(a.shape + (2, 2))
    phi[..., 0, 0] = a
    phi[..., 0, 1] = sgn * b
    phi[..., 1, 0] = sgn * c
    phi[..., 1, 1] = d
    if np.any(m != 0):
        M = monodromy(x, jj, system)
        Minv = np.empty_like(M)  # adjugate: det M = 1
        Minv[..., 0, 0] = M[..., 1, 1]
        Minv[..., 1, 1] = M[..., 0, 0]
        Minv[..., 0, 1] = -M[..., 0, 1]
        Minv[..., 1, 0] = -M[..., 1, 0]
        m = np.broadcast_to(m, phi.shape[:-2])
        base = np.where((m < 0)[..., None, None], np.broadcast_to(Minv, phi.shape), M)
        e = np.abs(m).astype(np.int64)
        while np.any(e > 0):  # binary powers, per element
            odd = (e & 1).astype(bool)[..., None, None]
            phi = np.where(odd, phi @ base, phi)
            base = base @ base
            e = e >> 1
    return phi
