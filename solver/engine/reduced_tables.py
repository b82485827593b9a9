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

The time and the angle alpha around the rim need omega3 / (1 - x cos beta) = P1 G21 + P2 G22 with
G = Phi[1] / (1 - x cos beta).

This module builds, once per (rho/R, j) and beta range, a piecewise Chebyshev table of those
functions and of sin beta: panels of width ``PANEL_WIDTH`` on a grid through beta = 0, ``N_COEF``
coefficients each, and their values at the ``N_NODES`` Gauss-Kronrod nodes of each panel (a
quadrature over a whole panel then needs no series evaluation: ``Table.nodes``).
Phi at the Chebyshev-Lobatto points of each panel comes
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
PHI11, PHI12, PHI21, PHI22, Q11, Q12, Q22, S11, S12, S22, SIN, G21, G22 = range(13)
N_FUNCTIONS = 13
NODE_FUNCTIONS = (SIN, Q11, Q12, Q22, S11, S12, S22, G21, G22)
SPREAD_FUNCTIONS = (SIN, Q11, Q12, Q22, S11, S12, S22)
"""The functions whose spread sum_{n>=1} |c_n| on each panel is tabled (``Table.spread``)."""
"""The functions tabled at the Gauss-Kronrod nodes (axis 1 of ``Table.nodes``, in this order)."""
N_NODES = 15
"""Gauss-Kronrod nodes per panel (the 7-point Gauss rule is embedded at the odd nodes)."""

_A = _A853[:12, :12]
_B = _A853[12, :12]
_C = np.array(_DOP853_C[:12])


class Table(NamedTuple):
    """A table of the reduced dynamics: ``values`` (n_panels, N_FUNCTIONS, N_COEF) Chebyshev
    coefficients of Phi, Q, S, sin beta and G on each panel (local variable u in [-1, 1]); ``nodes``
    (n_panels, len(NODE_FUNCTIONS), N_NODES) the values of NODE_FUNCTIONS at the panel's
    Gauss-Kronrod nodes (``kronrod()``); ``spread`` (n_panels, len(SPREAD_FUNCTIONS)) sum_{n>=1} |c_n| of
    their series (a function differs from its c_0 by at most that on the panel); ``beta_lo`` [rad] the left
    edge of panel 0; ``width`` [rad]
    the panel width; x = rho/R, k = j/(1+j)."""

    values: np.ndarray
    nodes: np.ndarray
    spread: np.ndarray
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


def kronrod():
    """The 15-point Gauss-Kronrod rule on [-1, 1]: (nodes, Kronrod weights, weights of the embedded
    7-point Gauss rule at the odd nodes 1, 3, ..., 13, zero elsewhere), nodes increasing."""
    xk = np.array([0.991455371120812639206854697526329, 0.949107912342758524526189684047851,
                   0.864864423359769072789712788640926, 0.741531185599394439863864773280788,
                   0.586087235467691130294144845693013, 0.405845151377397166906606412076961,
                   0.207784955007898467600689403773245, 0.0])
    wk = np.array([0.022935322010529224963732008058970, 0.063092092629978553290700663189204,
                   0.104790010322250183839876322541518, 0.140653259715525918745189590510238,
                   0.169004726639267902826583426598550, 0.190350578064785409913256402421014,
                   0.204432940075298892414161999234649, 0.209482141084727828012999174891714])
    wg = np.array([0.0, 0.129484966168869693270611432679082, 0.0, 0.279705391489276667901467771423780,
                   0.0, 0.381830050505118944950369775488975, 0.0, 0.417959183673469387755102040816327])
    nodes = np.concatenate([-xk, xk[-2::-1]])
    return nodes, np.concatenate([wk, wk[-2::-1]]), np.concatenate([wg, wg[-2::-1]])


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
    e = 1.0 / (1.0 - x * c)
    s_fac = c * e
    p11, p12, p21, p22 = phi
    vals = np.stack([p11, p12, p21, p22,
                     k * p11 * p11 + p21 * p21, k * p11 * p12 + p21 * p22, k * p12 * p12 + p22 * p22,
                     s_fac * p21 * p21, s_fac * p21 * p22, s_fac * p22 * p22,
                     np.sin(nodes), e * p21, e * p22], axis=1)  # (n_pan, F, N)
    coef = vals @ _fit_matrix().T
    gk = np.polynomial.chebyshev.chebvander(kronrod()[0], N_COEF - 1)  # (N_NODES, N_COEF)
    at_nodes = coef[:, list(NODE_FUNCTIONS), :] @ gk.T
    spread = np.abs(coef[:, list(SPREAD_FUNCTIONS), 1:]).sum(axis=-1) * (1.0 + 1e-12)
    return Table(np.ascontiguousarray(coef), np.ascontiguousarray(at_nodes), np.ascontiguousarray(spread),
                 float(left[0]), float(w), x, k)


def evaluate_many(table: Table, beta, functions) -> np.ndarray:
    """Values (len(functions), n) of tabled functions (PHI11 .. G22) at the points beta (n,) [rad] (numpy)."""
    beta = np.asarray(beta, dtype=float).reshape(-1)
    i = np.clip(np.floor((beta - table.beta_lo) / table.width).astype(int), 0, table.values.shape[0] - 1)
    u = 2.0 * (beta - table.beta_lo - i * table.width) / table.width - 1.0
    t = np.empty((N_COEF, beta.size))
    t[0] = 1.0
    t[1] = u
    for n in range(2, N_COEF):
        t[n] = 2.0 * u * t[n - 1] - t[n - 2]
    coef = np.moveaxis(table.values[:, list(functions), :], 0, -1)  # (F, N_COEF, n_panels)
    return np.einsum("fkn,kn->fn", coef[:, :, i], t)


def evaluate(table: Table, beta, function):
    """Value of a tabled function (PHI11 .. S22) at beta [rad] (numpy, broadcasting; for tests)."""
    beta = np.asarray(beta, dtype=float)
    i = np.clip(np.floor((beta - table.beta_lo) / table.width).astype(int), 0, table.values.shape[0] - 1)
    u = 2.0 * (beta - table.beta_lo - i * table.width) / table.width - 1.0
    return np.polynomial.chebyshev.chebval(u, table.values[i, function].T, tensor=False)
