"""Finite differences for the tests that check an analytic derivative (tests/solver/physics)."""

from __future__ import annotations

import numpy as np


def gradient(f, x):
    """Central finite-difference gradient of a scalar function of a state vector."""
    grad = np.empty(len(x))
    for k in range(len(x)):
        h = 1e-6 * max(1, abs(x[k]))
        xp, xm = x.copy(), x.copy()
        xp[k] += h
        xm[k] -= h
        grad[k] = (f(xp) - f(xm)) / (2 * h)
    return grad
