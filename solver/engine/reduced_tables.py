"""Tables of the reduced conservative rolling dynamics (paper Sect. 4.4), one per (rho/R, j).

Without dissipation omega2_dot and omega3_dot of (34)-(35) are proportional to omega1, so along a
rolling solution z = (omega2, omega3) is a function of beta alone, z(beta) = Phi(beta) P, with
Phi the fundamental matrix of (62) (Phi(0) = I),

    dPhi/dbeta = A(beta) Phi,   A = [[0, 1/(1 - x cos beta)], [-k, -x sin beta/(1 - x cos beta)]],

x = rho/R, k = j/(1+j), and P = Phi(beta0)^-1 z0 the level of the conserved quantities (68)
(P_I, P_II with c_I = (1, 0), c_II = (0, 1)). On a level the energy (60) and the normal force (31)
are linear combinations of fixed functions of beta with per-state coefficients:

    omega1^2(beta) = C0 - a sin beta - (P1^2 Q11 + 2 P1 P2 Q12 + P2^2 Q22)(beta),   a = 2 g rho / ((1+j) r^2)
    F2/m (beta)    = (r^2/R)(P1^2 S11 + 2 P1 P2 S12 + P2^2 S22)(beta) - (r^2/rho) omega1^2(beta) + g sin beta

with Q = Phi^T diag(k, 1) Phi (k omega2^2 + omega3^2 = P^T Q P) and S = cos beta / (1 - x cos beta)
Phi^T e2 e2^T Phi (omega3^2 cos beta/(1 - x cos beta) = P^T S P).

This module builds, once per (rho/R, j) and beta range, a piecewise Chebyshev table of those
functions: panels of width ``PANEL_WIDTH`` on a grid through beta = 0, ``N_COEF`` coefficients
each, plus the coefficients of the derivatives of Q and S and rigorous bounds of the second
derivatives of the Chebyshev polynomials on each panel (Markov's inequality for T_n'':
|T_n''| <= n^2 (n^2 - 1)/3 on [-1, 1]). Phi at the Chebyshev-Lobatto points of each panel comes
from the panel's own fundamental matrix (12-stage 8th-order DOP853 steps, ``SUBSTEPS`` per node,
vectorised over all nodes), chained from beta = 0 outward by 2x2 products (the inverse by the
adjugate, det Phi = (1 - x)/(1 - x cos beta) (Liouville)). Relative accuracy ~1e-15 of the table
values (checked in tests/solver/engine/test_reduced_rolling.py against ``solver.analysis.floquet.fundamental``).
Pure numpy: building a table takes milliseconds and no compilation.
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np

from rimroll.solver.engine.tableaus import _A853, _DOP853_C

PANEL_WIDTH = np.pi / 32
"""Width of a table panel [rad]."""
N_COEF = 16
"""Chebyshev coefficients per panel and function (degree 15)."""
SUBSTEPS = 6
"""DOP853 steps from a panel's left edge to each of its nodes."""

# functions of the value table (axis 1 of ``Table.values``)
PHI11, PHI12, PHI21, PHI22, Q11, Q12, Q22, S11, S12, S22 = range(10)
N_FUNCTIONS = 10
N_FORMS = 6
"""Q11, Q12, Q22, S11, S12, S22: the forms whose derivatives and second-derivative bounds are tabled."""

_A = _A853[:12, :12]
_B = _A853[12, :12]
_C = np.array(_DOP853_C[:12])


class Table(NamedTuple):
    """A table of the reduced dynamics: ``values`` (n_panels, N_FUNCTIONS, N_COEF) Chebyshev
    coefficients of Phi, Q, S on each panel (local variable u in [-1, 1]); ``slopes`` (n_panels,
    N_FORMS, N_COEF) those of dQ/dbeta, dS/dbeta [1/rad]; ``curvature`` (n_panels, N_FORMS) bounds of
    |d^2/dbeta^2| of the forms' polynomials on each panel [1/rad^2]; ``beta_lo`` [rad] the left edge of
    panel 0; ``width`` [rad] the panel width; x = rho/R, k = j/(1+j)."""

    values: np.ndarray
    slopes: np.ndarray
    curvature: np.ndarray
    beta_lo: float
    width: float
    x: float
    k: float

    @property
    def beta_hi(self) -> float:
        """The right edge of the last panel [rad]."""
        return self.beta_lo + self.width * self.values.shape[0]


def _rates(beta, phi, x, k):
    """dPhi/dbeta = A(beta) Phi for Phi (4, ...) stored as (11, 12, 21, 22)."""
    c = np.cos(beta)
    e = 1.0 / (1.0 - x * c)
    o = x * np.sin(beta) * e
    return np.stack([e * phi[2], e * phi[3], -k * phi[0] - o * phi[2], -k * phi[1] - o * phi[3]])


def _local_fundamental(left, nodes, x, k):
    """Fundamental matrix of (62) from beta = left to beta = nodes (identity at left), (4, ...)."""
    shape = np.broadcast_shapes(np.shape(left), np.shape(nodes))
    phi = np.zeros((4,) + shape)
    phi[0] = 1.0
    phi[3] = 1.0
    h = (nodes - left) / SUBSTEPS
    K = np.empty((12, 4) + shape)
    for n in range(SUBSTEPS):
        b0 = left + n * h
        for s in range(12):
            y = phi + h * np.tensordot(_A[s, :s], K[:s], axes=(0, 0)) if s else phi
            K[s] = _rates(b0 + _C[s] * h, y, x, k)
        phi = phi + h * np.tensordot(_B, K, axes=(0, 0))
    return phi


def _mul(a, b):
    """2x2 products of (4, ...) matrices stored as (11, 12, 21, 22)."""
    return np.stack([a[0] * b[0] + a[1] * b[2], a[0] * b[1] + a[1] * b[3],
                     a[2] * b[0] + a[3] * b[2], a[2] * b[1] + a[3] * b[3]])


def _inverse(a):
    det = a[0] * a[3] - a[1] * a[2]
    return np.stack([a[3], -a[1], -a[2], a[0]]) / det


def lobatto(n=N_COEF):
    """Chebyshev-Lobatto points cos(pi i/(n-1)), i = 0..n-1, on [-1, 1] (decreasing)."""
    return np.cos(np.pi * np.arange(n) / (n - 1))


def _fit_matrix(n=N_COEF):
    """Matrix that maps values at the Lobatto points to Chebyshev coefficients (interpolation)."""
    u = lobatto(n)
    return np.linalg.inv(np.polynomial.chebyshev.chebvander(u, n - 1))


def curvature_bound(coef, width):
    """Bound of |p''(beta)| [1/rad^2] on a panel of ``width`` [rad] for the Chebyshev series ``coef``
    (last axis) in u = 2 (beta - left)/width - 1: (2/width)^2 sum |c_n| n^2 (n^2 - 1)/3 (Markov)."""
    n = np.arange(coef.shape[-1], dtype=float)
    return (2.0 / width) ** 2 * np.sum(np.abs(coef) * n * n * (n * n - 1.0) / 3.0, axis=-1)


def build(rho_over_R, j, beta_min, beta_max) -> Table:
    """The table of (62) for x = rho_over_R in (0, 1), j > 0 covering [beta_min, beta_max] [rad]
    (and beta = 0, where Phi = I)."""
    x = float(rho_over_R)
    k = float(j) / (1.0 + float(j))
    w = PANEL_WIDTH
    i_lo = int(np.floor(min(beta_min, 0.0) / w)) - 1
    i_hi = int(np.ceil(max(beta_max, 0.0) / w)) + 1
    idx = np.arange(i_lo, i_hi)
    left = idx * w
    u = lobatto()
    nodes = left[:, None] + 0.5 * w * (u[None, :] + 1.0)  # u[0] = 1: the right edge; u[-1] = -1: the left edge
    local = _local_fundamental(left[:, None], nodes, x, k)  # (4, n_panels, N_COEF)
    step = local[:, :, 0]  # panel transfer matrices, left -> right edge
    # Phi at each left edge, chained from beta = 0 (panel index 0 starts there)
    n_pan = len(idx)
    start = np.empty((4, n_pan))
    zero = -i_lo
    start[:, zero] = (1.0, 0.0, 0.0, 1.0)
    for m in range(zero + 1, n_pan):
        start[:, m] = _mul(step[:, m - 1][:, None], start[:, m - 1][:, None])[:, 0]
    for m in range(zero - 1, -1, -1):
        start[:, m] = _mul(_inverse(step[:, m][:, None]), start[:, m + 1][:, None])[:, 0]
    phi = _mul(local, start[:, :, None])  # (4, n_panels, N_COEF)
    c = np.cos(nodes)
    s_fac = c / (1.0 - x * c)
    p11, p12, p21, p22 = phi
    vals = np.stack([p11, p12, p21, p22,
                     k * p11 * p11 + p21 * p21, k * p11 * p12 + p21 * p22, k * p12 * p12 + p22 * p22,
                     s_fac * p21 * p21, s_fac * p21 * p22, s_fac * p22 * p22], axis=1)  # (n_pan, F, N)
    coef = vals @ _fit_matrix().T
    forms = coef[:, Q11:, :]
    slopes = np.zeros_like(forms)
    slopes[..., :-1] = np.polynomial.chebyshev.chebder(forms, axis=-1) * (2.0 / w)
    return Table(np.ascontiguousarray(coef), np.ascontiguousarray(slopes), curvature_bound(forms, w),
                 float(left[0]), float(w), x, k)


def evaluate(table: Table, beta, function):
    """Value of a tabled function (PHI11 .. S22) at beta [rad] (numpy, broadcasting; for tests)."""
    beta = np.asarray(beta, dtype=float)
    i = np.clip(np.floor((beta - table.beta_lo) / table.width).astype(int), 0, table.values.shape[0] - 1)
    u = 2.0 * (beta - table.beta_lo - i * table.width) / table.width - 1.0
    return np.polynomial.chebyshev.chebval(u, table.values[i, function].T, tensor=False)
