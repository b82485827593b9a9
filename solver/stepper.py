"""One generic embedded Runge-Kutta step, its error norm, step-size control and dense output.

Everything here reads a method from the arrays of a :class:`solver.tableaus.Tableau` (``A``,
``C``, ``E``, ``P`` and a few integers) and the right-hand side from
:func:`solver.system.rhs` (selected by the integer ``phase``), so DP5 and DOP853 share every
line. State vectors are rows of preallocated float64 work arrays; ``n`` is the number of live
components and the first ``n_err`` of them enter the error norm (the quadrature of alpha,
stored last, does not steer the step size).

Step-size control is the classic one of Hairer, Norsett & Wanner (Solving ODEs I, II.4), as in
``scipy.integrate.RK45``: ``h_new = h * clip(SAFETY * err^(-1/(q+1)), MIN_FACTOR, MAX_FACTOR)``
with ``q`` the order of the error estimator, and no growth right after a rejected step.
"""

from __future__ import annotations

import numpy as np

from solver._compile import kernel
from solver.system import rhs, rhs_row

SAFETY = 0.9  # fraction of the optimal step actually taken
MIN_FACTOR = 0.2  # largest decrease of h in one rejection (also the cut after a non-finite trial)
MAX_FACTOR = 10.0  # largest increase of h after an accepted step
MIN_STEP_ULPS = 10.0  # h below this many ulps of t is a step-size underflow (as scipy)


@kernel(inline=True)
def rk_step(phase, t, y, f, h, n, A, n_stages, K, y_new, tmp, p):
    """One explicit RK step from (t, y) with slope f = rhs(y): fills K[0..n_stages] and y_new.

    K[n_stages] is the first-same-as-last stage f(y_new), reused by the next step, the error
    estimate and the dense output. (t does not enter: the system is autonomous.)
    """
    for i in range(n):
        K[0, i] = f[i]
    for s in range(1, n_stages + 1):
        for i in range(n):
            acc = 0.0
            for j in range(s):
                acc += A[s, j] * K[j, i]
            tmp[i] = y[i] + h * acc
        if s == n_stages:
            for i in range(n):
                y_new[i] = tmp[i]
        rhs_row(phase, tmp, p, K, s)


@kernel(inline=True)
def error_norm(K, E, err_mode, n_stages, h, y, y_new, n_err, rtol, atol):
    """Scaled norm of the local error estimate; the step is accepted when it is <= 1.

    The scale of component i is atol + rtol * max(|y_i|, |y_new_i|). err_mode 0: RMS of
    h K^T E[0] / scale; err_mode 1: the DOP853 combination of its two estimators.
    """
    if err_mode == 0:
        acc = 0.0
        for i in range(n_err):
            e = 0.0
            for k in range(n_stages + 1):
                e += K[k, i] * E[0, k]
            sc = atol + rtol * max(abs(y[i]), abs(y_new[i]))
            e = h * e / sc
            acc += e * e
        return np.sqrt(acc / n_err)
    n5 = 0.0
    n3 = 0.0
    for i in range(n_err):
        e5 = 0.0
        e3 = 0.0
        for k in range(n_stages + 1):
            e5 += K[k, i] * E[0, k]
            e3 += K[k, i] * E[1, k]
        sc = atol + rtol * max(abs(y[i]), abs(y_new[i]))
        n5 += (e5 / sc) ** 2
        n3 += (e3 / sc) ** 2
    if n5 == 0.0 and n3 == 0.0:
        return 0.0
    return abs(h) * n5 / np.sqrt((n5 + 0.01 * n3) * n_err)


@kernel(inline=True)
def step_factor(err, exponent, after_reject):
    """Factor for the next step from the error norm of an accepted (err <= 1) or rejected step."""
    if err == 0.0:
        factor = MAX_FACTOR
    else:
        factor = SAFETY * err**exponent
    if err > 1.0:
        return max(MIN_FACTOR, min(factor, 1.0))
    factor = min(MAX_FACTOR, factor)
    if after_reject:
        factor = min(1.0, factor)
    return factor


@kernel(inline=True)
def min_step(t):
    """Smallest step allowed at time t (MIN_STEP_ULPS ulps of t) [s]."""
    return MIN_STEP_ULPS * (np.nextafter(abs(t), np.inf) - abs(t))


@kernel
def initial_step(phase, y, f, n, n_err, error_order, rtol, atol, span, tmp, f1, p):
    """Hairer's starting step (Solving ODEs I, II.4; scipy ``select_initial_step``) [s].

    Uses one extra evaluation of the right-hand side; bounded by ``span`` (time left).
    """
    d0 = 0.0
    d1 = 0.0
    for i in range(n_err):
        sc = atol + rtol * abs(y[i])
        d0 += (y[i] / sc) ** 2
        d1 += (f[i] / sc) ** 2
    d0 = np.sqrt(d0 / n_err)
    d1 = np.sqrt(d1 / n_err)
    if d0 < 1e-5 or d1 < 1e-5:
        h0 = 1e-6
    else:
        h0 = 0.01 * d0 / d1
    h0 = min(h0, span)
    for i in range(n):
        tmp[i] = y[i] + h0 * f[i]
    rhs(phase, tmp, p, f1)
    d2 = 0.0
    for i in range(n_err):
        sc = atol + rtol * abs(y[i])
        d2 += ((f1[i] - f[i]) / sc) ** 2
    d2 = np.sqrt(d2 / n_err) / h0
    if not np.isfinite(d2):
        return h0
    if d1 <= 1e-15 and d2 <= 1e-15:
        h1 = max(1e-6, h0 * 1e-3)
    else:
        h1 = (0.01 / max(d1, d2)) ** (1.0 / (error_order + 1.0))
    return min(100.0 * h0, h1, span)


@kernel
def dense_prepare(phase, y, h, n, A, n_stages, n_dense, P, n_poly, K, Q, tmp, p):
    """Dense output of the last step: extra stages (if the method has any), then Q = K^T P.

    Afterwards ``dense_eval(theta, y, h, Q, ...)`` gives the interpolant on [t, t + h].
    """
    for s in range(n_stages + 1, n_dense):
        for i in range(n):
            acc = 0.0
            for j in range(s):
                acc += A[s, j] * K[j, i]
            tmp[i] = y[i] + h * acc
        rhs_row(phase, tmp, p, K, s)
    for i in range(n):
        for q in range(n_poly):
            acc = 0.0
            for k in range(n_dense):
                acc += K[k, i] * P[k, q]
            Q[i, q] = acc


@kernel
def dense_eval(theta, y, h, Q, n, n_poly, out):
    """The dense output at t + theta h (0 <= theta <= 1) into ``out[:n]``."""
    for i in range(n):
        acc = 0.0
        for q in range(n_poly - 1, -1, -1):
            acc = (acc + Q[i, q]) * theta
        out[i] = y[i] + h * acc
