"""Steady motions of the rolling ball in closed form: (47)-(48), the trivial ones (46), and h of (54).

A non-trivial steady motion (47) is fixed by the height angle beta0 [rad] and the circular
angular velocity omega30 [1/s]; (48) gives the orthogonal angular velocity omega20 [1/s] it
needs, and h (54) [1/s^2] the squared non-zero eigenvalues of the rolling equations linearised
about it. Every function broadcasts over numpy arrays of beta0 and omega30 and takes a
``Params`` (TypeError naming ``p`` otherwise). Points on the singular lines cos(beta0) = 0 or
omega30 = 0 give inf/NaN, never an exception, and so do NaN or inf in beta0 or omega30 (NaN in,
NaN out: a map keeps its shape). Their limits (slipping, falling, the energy of a throw) are
``solver.analysis.steady``.
"""

from __future__ import annotations

import numpy as np

from rimroll.solver._arguments import one_of
from rimroll.solver.physics.params import Params


def check_params(p, name: str = "p") -> None:
    """TypeError naming ``name`` unless ``p`` is a :class:`Params` (a dict of parameters is not one:
    ``Params(**d)`` makes one)."""
    if not isinstance(p, Params):
        raise TypeError(f"`{name}` must be a rimroll.solver.Params (e.g. Params(mu=1.0)); "
                        f"got {type(p).__name__} {p!r}")


def omega20(beta0, omega30, p: Params):
    """Orthogonal angular velocity (48) [1/s] of the non-trivial steady motion at beta0 [rad], omega30 [1/s].

    inf or NaN on the singular lines cos(beta0) = 0, omega30 = 0 and where beta0 or omega30 is NaN.
    """
    check_params(p)
    beta0 = np.asarray(beta0, dtype=float)
    omega30 = np.asarray(omega30, dtype=float)
    with np.errstate(divide="ignore", invalid="ignore"):
        return (1 + p.j) * omega30 * np.sin(beta0) / (p.j * np.cos(beta0)) - p.g * (
            p.R - p.rho * np.cos(beta0)
        ) / (p.j * p.r**2 * omega30)


def steady_state(beta0, omega30, p: Params):
    """The rolling state (beta0 [rad], 0, omega20 [1/s], omega30 [1/s]) of the steady motion (47).

    beta0 [rad], the height angle, and omega30 [1/s], the circular angular velocity: numbers or
    array_likes that broadcast; omega20 from (48). Returns an array of shape
    broadcast(beta0, omega30) + (4,). A NaN (inf) beta0 or omega30, a scalar included, gives NaN
    (inf or NaN) entries in its state, no exception; so do the singular lines cos(beta0) = 0 and
    omega30 = 0 (omega20 infinite). TypeError unless ``p`` is a ``Params``.
    """
    check_params(p)
    beta0, omega30 = np.broadcast_arrays(np.asarray(beta0, float), np.asarray(omega30, float))
    return np.stack([beta0, np.zeros_like(beta0), omega20(beta0, omega30, p), omega30], axis=-1)


def trivial_state(sign: int, omega20_value, p: Params):
    """Trivial steady motion x0+ (sign=+1, ball on top) or x0- (sign=-1, hanging) of (46); another
    sign (0, 2, NaN, True) raises ValueError naming ``sign``.

    The state (+-pi/2 [rad], 0, omega20_value [1/s], 0) for each omega20_value (any number: the
    spin of the ball about the normal), shape omega20_value.shape + (4,).
    """
    check_params(p)
    sign = one_of("sign", np.asarray(sign) if np.ndim(sign) else sign, (1, -1))
    w2 = np.asarray(omega20_value, float)
    beta = np.full_like(w2, np.pi / 2 * np.sign(sign))
    zero = np.zeros_like(w2)
    return np.stack([beta, zero, w2, zero], axis=-1)


def stability(beta0, omega30, p: Params):
    """h(beta0, omega30) of (54) [1/s^2] at beta0 [rad], omega30 [1/s]: the squared non-zero eigenvalues
    of the linearisation about the steady motion (47).

    h < 0: a neutrally stable centre (eigenvalues +-i sqrt(-h)); h > 0: a saddle (+-sqrt(h)).
    """
    check_params(p)
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
