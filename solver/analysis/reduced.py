"""The reduced (beta, omega1) dynamics of the conservative rolling ball (paper Sect. 4.4).

Without dissipation omega2_dot and omega3_dot of (34)-(35) are proportional to omega1, so along
a solution z = (omega2, omega3) is a function of beta alone: z(beta) = Phi(beta) P, with Phi the
fundamental matrix of (62) (Phi(0) = I, :func:`solver.floquet.fundamental`) and P = (P_I, P_II)
the conserved quantities (68) (P_I = omega2 and P_II = omega3 where beta = 0,
:func:`solver.invariants.momenta`). On a level set of (P_I, P_II) what is left is a planar
conservative system,

    beta_dot = (r/rho) omega1,    omega1_dot = G_P(beta) := omega1_dot of (33) at (beta, 0, z(beta)),

with the energy (60) E = 1/2 m (1+j) r^2 omega1^2 + U_P(beta), U_P the energy (60) at
(beta, 0, z(beta)), and G_P = -(r/rho) U_P' / (m (1+j) r^2). This is the "planar conservative
system with centres, saddles and the heteroclinic or homoclinic connections of saddles" of
Sect. 4.4. Its equilibria (omega1 = 0, G_P(beta*) = 0) are the equilibria of (33)-(36) on that
level: steady motions (47)-(48), or the trivial x0+- of (46) where cos(beta*) = 0 and
omega3 = 0. One with lambda^2 = (r/rho) G_P'(beta*) > 0 is a saddle whose stable and unstable
manifolds in the plane are the connections of Theorem 1 (types 3 and 4); lambda^2 is then h of
(54) (g / (rho (1+j)) at x0+), the one non-zero eigenvalue pair of the 4-D linearisation.

Only ``rho/R`` and ``j`` enter Phi; the functions take a conservative :class:`solver.Params`
(TypeError naming ``p`` for anything else). Units: beta [rad]; omega1, omega2, omega3 and the level
P = (P_I, P_II) [1/s].
"""

from __future__ import annotations

import numpy as np

from rimroll.solver._arguments import real_number
from rimroll.solver._jit import vectorised
from rimroll.solver.analysis import floquet, steady
from rimroll.solver.analysis.invariants import momenta
from rimroll.solver.physics import rolling
from rimroll.solver.physics.params import Params
from rimroll.solver.physics.steady_motion import check_params

_rhs = vectorised(rolling.rolling_rhs)

NEWTON_MAX_ITER = 50
NEWTON_BETA_TOL = 1e-13
"""Newton stops when the step in beta is below this [rad]."""
NEWTON_MAX_STEP = 0.2
"""Largest Newton step in beta [rad]: a step that would leave the basin of the nearest root is cut."""
DERIVATIVE_STEP = 1e-6
"""Step in beta [rad] of the central difference for G_P' (G_P is smooth; error ~1e-12 relative)."""
TRIVIAL_TOL = 1e-9
"""An equilibrium is the trivial x0+- when |cos beta*| and |omega3*| / omega_scale are below this."""


def _conservative(p: Params) -> None:
    check_params(p)
    if p.dissipative:
        raise ValueError(f"the reduced dynamics needs the conservative rolling equations: k_r = k_d = 0; "
                         f"got k_r={p.k_r}, k_d={p.k_d}")


def level(x, p: Params):
    """(P_I, P_II) [1/s] of the rolling state(s) x (..., 4) = (beta [rad], omega1, omega2, omega3 [1/s]):
    shape (..., 2)."""
    check_params(p)
    x = np.asarray(x, dtype=float)
    return np.stack(momenta(x[..., 0], x[..., 2], x[..., 3], p.rho / p.R, p.j), axis=-1)


def spins(beta, P, p: Params):
    """z(beta) = Phi(beta) P = (omega2, omega3) [1/s] at beta [rad] on the level P = (P_I, P_II) [1/s]
    (last axis 2; ValueError naming P otherwise): shape (..., 2)."""
    check_params(p)
    P = np.asarray(P, dtype=float)
    if P.shape[-1:] != (2,):
        raise ValueError(f"`P` must be the level (P_I, P_II) [1/s], shape (..., 2); got shape {P.shape}")
    phi = floquet.fundamental(beta, p.rho / p.R, p.j)
    return np.einsum("...ik,...k->...i", phi, P)


def state_on_level(beta, omega1, P, p: Params):
    """The rolling state (beta [rad], omega1 [1/s], z(beta) [1/s]) on the level P = (P_I, P_II) [1/s].

    beta and omega1 broadcast; P has shape (2,) or one that broadcasts with them plus a last axis of 2
    (ValueError naming P otherwise). Returns shape broadcast(beta, omega1) + (4,).
    """
    beta, omega1 = np.broadcast_arrays(np.asarray(beta, float), np.asarray(omega1, float))
    z = spins(beta, P, p)
    return np.stack([beta, omega1, z[..., 0], z[..., 1]], axis=-1)


def omega1_rate(beta, P, p: Params):
    """G_P(beta) [1/s^2]: omega1_dot of (33) at (beta, 0, z(beta)) (it does not depend on omega1)."""
    _conservative(p)
    z = spins(beta, P, p)
    return _rhs(np.asarray(beta, float), 0.0, z[..., 0], z[..., 1], p.as_array())[1]


def potential(beta, P, p: Params):
    """U_P(beta) [J]: the energy (60) of the state (beta, 0, z(beta)) (omega1 = 0)."""
    x = state_on_level(beta, 0.0, P, p)
    return vectorised(rolling.energy)(x[..., 0], x[..., 1], x[..., 2], x[..., 3], p.as_array())


def omega1_rate_slope(beta, P, p: Params):
    """G_P'(beta) [1/(s^2 rad)] by a central difference of step DERIVATIVE_STEP."""
    h = DERIVATIVE_STEP
    return (omega1_rate(np.asarray(beta, float) + h, P, p) - omega1_rate(np.asarray(beta, float) - h, P, p)) / (2 * h)


def equilibrium(P, beta_guess: float, p: Params):
    """The equilibrium of the reduced dynamics on the level P nearest (by Newton) to beta_guess.

    Newton's method on G_P(beta) = 0 from beta_guess [rad] (steps limited to NEWTON_MAX_STEP).
    Returns the state x* = (beta*, 0, omega2*, omega3*) (shape (4,)), or NaNs where Newton does
    not converge within NEWTON_MAX_ITER iterations. beta* is a real number, not reduced mod 2 pi.
    P: the level (P_I, P_II) [1/s].
    """
    _conservative(p)
    beta = real_number("beta_guess", beta_guess, allowed="an angle [rad]")
    for _ in range(NEWTON_MAX_ITER):
        g = float(omega1_rate(beta, P, p))
        slope = float(omega1_rate_slope(beta, P, p))
        if not (np.isfinite(g) and np.isfinite(slope)) or slope == 0.0:
            break
        step = float(np.clip(-g / slope, -NEWTON_MAX_STEP, NEWTON_MAX_STEP))
        beta += step
        if abs(step) < NEWTON_BETA_TOL:
            return state_on_level(beta, 0.0, P, p)
    return np.full(4, np.nan)


def eigenvalue_squared(x_eq, p: Params) -> float:
    """lambda^2 [1/s^2] of the equilibrium x_eq (4,) of the reduced dynamics: (r/rho) G_P'(beta*).

    > 0: a saddle with rates +-lambda; < 0: a centre.
    """
    x_eq = np.asarray(x_eq, dtype=float)
    return float(p.r / p.rho * omega1_rate_slope(x_eq[0], level(x_eq, p), p))


def is_trivial(x_eq, p: Params) -> bool:
    """Whether the equilibrium x_eq is a trivial one, x0+- of (46): cos(beta) = 0 and omega3 = 0."""
    check_params(p)
    beta, _, w2, w3 = np.asarray(x_eq, dtype=float)
    scale = max(abs(w2), abs(w3), np.sqrt(p.g / p.rho))
    return bool(abs(np.cos(beta)) <= TRIVIAL_TOL and abs(w3) <= TRIVIAL_TOL * scale)


def saddle_rate(x_eq, p: Params) -> float:
    """The paper's eigenvalue lambda [1/s] of the equilibrium x_eq: sqrt(h) of (54) for a steady motion,
    sqrt(g / (rho (1+j))) for x0+ (``steady.trivial_eigenvalue``); NaN where it is not a saddle."""
    beta, _, _, w3 = np.asarray(x_eq, dtype=float)
    if is_trivial(x_eq, p):
        return steady.trivial_eigenvalue(p) if np.sin(beta) > 0 else float("nan")
    h = float(steady.stability(beta, w3, p))
    return float(np.sqrt(h)) if h > 0 else float("nan")


def stable_manifold_state(x_eq, offset, p: Params):
    """A state on the stable manifold of the saddle x_eq, at beta = beta* + offset [rad]: shape (4,).

    On the level (P_I, P_II) of x_eq and at its energy E*: omega1 from (60),
    1/2 m (1+j) r^2 omega1^2 = E* - U_P(beta), with the sign that carries beta towards beta*
    (beta_dot = (r/rho) omega1). The solution through it tends to x_eq as t -> inf if U_P < E*
    all the way from beta to beta*; raises ValueError where x_eq is not a saddle or that fails
    (the offset reaches past the saddle's own potential hill).
    """
    x_eq = np.asarray(x_eq, dtype=float)
    real_number("offset", offset, allowed="an angle [rad]")
    if not eigenvalue_squared(x_eq, p) > 0:
        raise ValueError(f"x_eq={x_eq} is not a saddle of the reduced dynamics (lambda^2 <= 0)")
    P = level(x_eq, p)
    e_star = float(potential(x_eq[0], P, p))
    path = x_eq[0] + np.linspace(0.0, float(offset), 201)[1:]
    kinetic = e_star - potential(path, P, p)
    if not np.all(kinetic > 0):
        raise ValueError(f"offset={offset!r} rad: U_P reaches E* between beta* and beta* + offset; take a smaller one")
    omega1 = -np.sign(offset) * np.sqrt(2.0 * kinetic[-1] / (p.m * (1.0 + p.j) * p.r**2))
    return state_on_level(path[-1], omega1, P, p)
