"""Conserved quantities of the rolling ball (paper Sect. 4.4, Props. 9-12): E (60), P_I, P_II (65)-(68).

Along the conservative rolling equations (33)-(36) (k_r = k_d = 0):

- the energy E (60) [J], with potential m g rho sin(beta) ((60) prints r, the
  equations conserve rho);
- P = c2(beta) omega2 + c3(beta) omega3 (65) [1/s] (c1 = 0) for every solution c = (c2, c3) of
  (66), dc/dbeta = -A(beta)^T c with A the matrix of (62). Derivation (checked, (66) is right as
  printed): with beta_dot = (r/rho) omega1, (34)-(35) read omega2_dot = beta_dot R/(R - rho cos)
  omega3 and omega3_dot = beta_dot (-rho sin/(R - rho cos) omega3 - j/(1+j) omega2), so
  dP/dt = beta_dot [(c2' - j/(1+j) c3) omega2 + (c3' + R/(R - rho cos) c2 - rho sin/(R - rho cos) c3)
  omega3], which vanishes for all omega2, omega3 iff (66) holds. Any omega1 term would need
  c1 = 0 (Prop. 9).

With Psi(beta) the fundamental matrix of (66), Psi(0) = I, (68) gives
P = [omega2, omega3] Psi(beta) c; we take c_I = (1, 0), c_II = (0, 1), so P_I, P_II are the
values of c . z at beta = 0: P_I = omega2 and P_II = omega3 where beta = 0 exactly (not
beta = 2 pi n: Psi is not periodic, Psi(beta + 2 pi) = Psi(beta) M^{-T}). Psi(beta) is computed by
``solver.floquet.fundamental`` at any real beta (~1e-13 relative).

Closed forms in the limits (R -> inf: Prop. 11, (69); R -> 0: Prop. 12, (72)) are given for
comparison; they span the same two-dimensional space as (P_I, P_II) up to a constant 2x2
recombination (68).
"""

from __future__ import annotations

import numpy as np

from rimroll.solver._jit import vectorised
from rimroll.solver.analysis import floquet
from rimroll.solver.physics import rolling
from rimroll.solver.physics.params import Params

_energy = vectorised(rolling.energy)


def momenta(beta, omega2, omega3, rho_over_R, j):
    """(P_I, P_II) of (68) with c_I = (1, 0), c_II = (0, 1) [1/s], broadcasting.

    beta [rad] (any real value), omega2, omega3 [1/s]; rho_over_R in (0, 1), j > 0.
    """
    psi = floquet.fundamental(beta, rho_over_R, j, system="coefficients")
    omega2 = np.asarray(omega2, dtype=float)
    omega3 = np.asarray(omega3, dtype=float)
    p_one = omega2 * psi[..., 0, 0] + omega3 * psi[..., 1, 0]
    p_two = omega2 * psi[..., 0, 1] + omega3 * psi[..., 1, 1]
    return p_one, p_two


def invariants(states, p: Params):
    """The three conserved quantities at each rolling state.

    states: array (..., 4) of (beta [rad], omega1, omega2, omega3 [1/s]); p: ``solver.Params``.
    Returns {"E": energy (60) [J], "P_I": (68) with c_I = (1, 0) [1/s], "P_II": with c_II = (0, 1)
    [1/s]}, each of shape states.shape[:-1]. Conserved by the conservative rolling equations
    (k_r = k_d = 0); P_I, P_II depend on rho, R only through rho/R.
    """
    states = np.asarray(states, dtype=float)
    if states.shape[-1:] != (4,):
        raise ValueError(f"states must have shape (..., 4), got {states.shape}")
    beta, omega1, omega2, omega3 = np.moveaxis(states, -1, 0)
    p_one, p_two = momenta(beta, omega2, omega3, p.rho / p.R, p.j)
    return {"E": _energy(beta, omega1, omega2, omega3, p.as_array()), "P_I": p_one, "P_II": p_two}


def prop11_invariants(beta, omega2, omega3, j):
    """(P_I, P_II) of (69), conserved in the limit R -> inf (rim a straight cylinder) [1/s].

    P_I = omega3 cos(w beta) + omega2 w sin(w beta), P_II = omega3 sin(w beta) - omega2 w cos(w beta),
    w = sqrt(j/(1+j)).
    """
    beta = np.asarray(beta, dtype=float)
    omega2 = np.asarray(omega2, dtype=float)
    omega3 = np.asarray(omega3, dtype=float)
    w = np.sqrt(np.asarray(j, dtype=float) / (1.0 + np.asarray(j, dtype=float)))
    cw, sw = np.cos(w * beta), np.sin(w * beta)
    return omega3 * cw + omega2 * w * sw, omega3 * sw - omega2 * w * cw


def prop12_invariants(beta, omega2, omega3, j):
    """(P_I, P_II) of (72), conserved in the limit R -> 0 (rim a sphere) [1/s].

    P_I = omega2, P_II = (1+j) omega3 cos(beta) + j omega2 sin(beta) (angular momentum about
    the vertical, divided by m r^2).
    """
    beta = np.asarray(beta, dtype=float)
    omega2 = np.asarray(omega2, dtype=float)
    omega3 = np.asarray(omega3, dtype=float)
    j = np.asarray(j, dtype=float)
    return omega2 + 0.0 * beta, (1.0 + j) * omega3 * np.cos(beta) + j * omega2 * np.sin(beta)
