"""Steady motions of the rolling ball in closed form: (47)-(48), the trivial ones (46), and h of (54).

A non-trivial steady motion (47) is fixed by the height angle beta0 [rad] and the circular
angular velocity omega30 [1/s]; (48) gives the orthogonal angular velocity omega20 [1/s] it
needs, and h (54) [1/s^2] the squared non-zero eigenvalues of the rolling equations linearised
about it. Every function broadcasts over numpy arrays of beta0 and omega30 and takes a
:class:`Params`. Points on the singular lines cos(beta0) = 0 or omega30 = 0 give inf/NaN, never
an exception. Their limits (slipping, falling, the energy of a throw) are ``solver.analysis.steady``.
"""

from __future__ import annotations

import numpy as np

from rimroll.solver.physics.params import Params


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
