"""A test system for the generic integrator: the harmonic oscillator with a quadrature.

y = (x, v, q): x' = v, v' = -x, q' = x; exact solution from (cos t0, -sin t0, sin t0) is
(cos(t + t0), -sin(t + t0), sin(t + t0)). Events: x, v and x - 1/2, with exact time
derivatives v, -x and v. Passed to ``solver.engine.stepper`` and ``solver.engine.events`` exactly as the
physics systems of ``solver.engine.system`` are, so the very same compiled integrator is checked
against closed forms.
"""

import math

import numba
import numpy as np

N = 3
N_EVENTS = 3
P = np.zeros(1)  # the oscillator has no parameters
AUX = np.zeros(1)


@numba.njit(cache=False)
def rhs(y, p, K, s):
    K[s, 0] = y[1]
    K[s, 1] = -y[0]
    K[s, 2] = y[0]


@numba.njit(cache=False)
def events(y, f, p, aux, g, gr):
    g[0] = y[0]
    gr[0] = f[0]
    g[1] = y[1]
    gr[1] = f[1]
    g[2] = y[0] - 0.5
    gr[2] = f[0]


def exact(t, t0=0.0):
    """Oscillator state at t starting from (cos t0, -sin t0, sin t0) at t = 0."""
    return np.array([math.cos(t + t0), -math.sin(t + t0), math.sin(t + t0)])


def pad(v, n=7):
    out = np.zeros(n)
    out[: len(v)] = v
    return out


def one_step(stepper, tab, y, h):
    """One RK step of size h from y: (y_new, K, Q) with the dense output prepared."""
    K = np.zeros((tab.n_dense, 7))
    rhs(y, P, K, 0)
    f = K[0].copy()
    y_new = np.zeros(7)
    tmp = np.zeros(7)
    stepper.rk_step(rhs, y, f, h, N, tab.A, tab.n_stages, K, y_new, tmp, P)
    Q = np.zeros((7, tab.n_poly))
    stepper.dense_prepare(rhs, tab.method, y, h, N, K, Q, tmp, P)
    return y_new, K, Q


def values(y, f=None):
    """Event values and rates at y (rates along f, or along the exact rhs)."""
    if f is None:
        K = np.zeros((1, 7))
        rhs(y, P, K, 0)
        f = K[0]
    g = np.zeros(N_EVENTS)
    gr = np.zeros(N_EVENTS)
    events(y, f, P, AUX, g, gr)
    return g, gr
