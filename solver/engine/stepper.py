"""One generic embedded Runge-Kutta step, its error norm, step-size control and dense output.

Everything here reads a method from the arrays of a :class:`solver.engine.tableaus.Tableau` (``A``,
``C``, ``E``, ``P`` and a few integers), so DP5 and DOP853 share every line, and knows no
physics: the right-hand side is a compiled function ``rhs(y, p, K, s)`` passed in (it writes
the rates of y into row s of the 2-D array K; ``p`` is whatever parameter vector it needs).
State vectors are preallocated float64 arrays; ``n`` is the number of live components and the
first ``n_err`` of them enter the error norm (a quadrature stored last, like the cyclic angle
of the ball, does not steer the step size).

:func:`accept_reject` is the step attempt of both step types (an explicit step here, a Rosenbrock step in
``solver.engine.rosenbrock``, passed in as its trial function): it tries steps from (t, y) until one is
accepted, rejecting on the error norm and cutting the step after a non-finite trial, and reports a step
budget spent or a step-size underflow instead of looping; :func:`attempt` is its explicit form.

Step-size control is the classic one of Hairer, Norsett & Wanner (Solving ODEs I, II.4), as in
``scipy.integrate.RK45``: ``h_new = h * clip(SAFETY * err^(-1/(q+1)), MIN_FACTOR, MAX_FACTOR)``
with ``q`` the order of the error estimator, and no growth right after a rejected step.
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np

from rimroll.solver._compile import engine_kernel

SAFETY = 0.9  # fraction of the optimal step actually taken
MIN_FACTOR = 0.2  # largest decrease of h in one rejection (also the cut after a non-finite trial)
MAX_FACTOR = 10.0  # largest increase of h after an accepted step
MIN_STEP_ULPS = 10.0  # h below this many ulps of t is a step-size underflow (as scipy)
MAX_NONFINITE_RETRIES = 30  # consecutive non-finite trial steps (each cutting h by MIN_FACTOR)

# Results of attempt().
ACCEPTED = 0
BUDGET_SPENT = 1
UNDERFLOW = 2
NON_FINITE = 3


@engine_kernel(inline=True, takes_functions=True)
def rk_step(rhs, y, f, h, n, A, n_stages, K, y_new, tmp, p):
    """One explicit RK step from y with slope f = rhs(y): fills K[0..n_stages] and y_new.

    K[n_stages] is the first-same-as-last stage f(y_new), reused by the next step, the error
    estimate and the dense output. (No time argument: the systems are autonomous.)
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
        rhs(tmp, p, K, s)


@engine_kernel(inline=True)
def error_norm(K, E, err_mode, n_stages, h, y, y_new, n_err, rtol, atol):
    """Scaled norm of the local error estimate; the step is accepted when it is <= 1.

    The scale of component i is atol[i] + rtol * max(|y_i|, |y_new_i|) (atol: one absolute
    tolerance per component, in its units). err_mode 0: RMS of
    h K^T E[0] / scale; err_mode 1: the DOP853 combination of its two estimators.
    """
    if err_mode == 0:
        acc = 0.0
        for i in range(n_err):
            e = 0.0
            for k in range(n_stages + 1):
                e += K[k, i] * E[0, k]
            sc = atol[i] + rtol * max(abs(y[i]), abs(y_new[i]))
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
        sc = atol[i] + rtol * max(abs(y[i]), abs(y_new[i]))
        n5 += (e5 / sc) ** 2
        n3 += (e3 / sc) ** 2
    if n5 == 0.0 and n3 == 0.0:
        return 0.0
    return abs(h) * n5 / np.sqrt((n5 + 0.01 * n3) * n_err)


@engine_kernel(inline=True)
def step_factor(err, exponent, after_reject, max_factor):
    """Factor for the next step from the error norm of an accepted (err <= 1) or rejected step; at
    most ``max_factor`` (MAX_FACTOR for the explicit methods, ``rosenbrock.MAX_FACTOR`` for Rodas4)."""
    if err == 0.0:
        factor = max_factor
    else:
        factor = SAFETY * err**exponent
    if err > 1.0:
        return max(MIN_FACTOR, min(factor, 1.0))
    factor = min(max_factor, factor)
    if after_reject:
        factor = min(1.0, factor)
    return factor


@engine_kernel(inline=True)
def min_step(t):
    """Smallest step allowed at time t (MIN_STEP_ULPS ulps of t) [s]."""
    return MIN_STEP_ULPS * (np.nextafter(abs(t), np.inf) - abs(t))


@engine_kernel(takes_functions=True)
def initial_step(rhs, y, f, n, n_err, error_order, rtol, atol, span, tmp, F1, p):
    """Hairer's starting step (Solving ODEs I, II.4; scipy ``select_initial_step``) [s].

    Uses one extra evaluation of the right-hand side (into row 0 of the scratch array F1);
    bounded by ``span`` (time left). atol: per component, as in :func:`error_norm`.
    """
    d0 = 0.0
    d1 = 0.0
    for i in range(n_err):
        sc = atol[i] + rtol * abs(y[i])
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
    rhs(tmp, p, F1, np.int64(0))  # int64, not Literal[int]: one compiled callee
    d2 = 0.0
    for i in range(n_err):
        sc = atol[i] + rtol * abs(y[i])
        d2 += ((F1[0, i] - f[i]) / sc) ** 2
    d2 = np.sqrt(d2 / n_err) / h0
    if not np.isfinite(d2):
        return h0
    if d1 <= 1e-15 and d2 <= 1e-15:
        h1 = max(1e-6, h0 * 1e-3)
    else:
        h1 = (0.01 / max(d1, d2)) ** (1.0 / (error_order + 1.0))
    return min(100.0 * h0, h1, span)


@engine_kernel(takes_functions=True)
def dense_prepare(rhs, method, y, h, n, K, Q, tmp, p):
    """Dense output of the last step: extra stages (if the method has any), then Q = K^T P.

    ``method`` is the :class:`~rimroll.solver.engine.tableaus.Method` record. Afterwards
    ``dense_eval(theta, y, h, Q, ...)`` gives the interpolant on [t, t + h] and ``dense_slope`` its
    time derivative.
    """
    A = method.A
    P = method.P
    n_stages = method.n_stages
    n_dense = A.shape[0]
    n_poly = P.shape[1]
    for s in range(n_stages + 1, n_dense):
        for i in range(n):
            acc = 0.0
            for j in range(s):
                acc += A[s, j] * K[j, i]
            tmp[i] = y[i] + h * acc
        rhs(tmp, p, K, s)
    for i in range(n):
        for q in range(n_poly):
            acc = 0.0
            for k in range(n_dense):
                acc += K[k, i] * P[k, q]
            Q[i, q] = acc


@engine_kernel
def dense_eval(theta, y, h, Q, n, n_poly, out):
    """The dense output at t + theta h (0 <= theta <= 1) into ``out[:n]``."""
    for i in range(n):
        acc = 0.0
        for q in range(n_poly - 1, -1, -1):
            acc = (acc + Q[i, q]) * theta
        out[i] = y[i] + h * acc


@engine_kernel
def dense_slope(theta, Q, n, n_poly, out):
    """Time derivative of the dense output at t + theta h into ``out[:n]`` [units of y per s].

    y(theta) = y + h sum_q Q[:, q] theta^(q+1), so dy/dt = sum_q (q + 1) Q[:, q] theta^q.
    """
    for i in range(n):
        acc = 0.0
        for q in range(n_poly - 1, 0, -1):
            acc = (acc + (q + 1) * Q[i, q]) * theta
        out[i] = acc + Q[i, 0]


class Control(NamedTuple):
    """The error control of a phase: live components ``n``, the first ``n_err`` of them in the error
    norm, rtol [1], atol per component [its units], and the end of the run t_end [s]."""

    n: int
    n_err: int
    rtol: float
    atol: np.ndarray
    t_end: float


class Arrays(NamedTuple):
    """The arrays of a step attempt: the state y, its slope f, the stages K (n_dense, >= n), the
    new state y_new and scratch tmp."""

    y: np.ndarray
    f: np.ndarray
    K: np.ndarray
    y_new: np.ndarray
    tmp: np.ndarray


class Stepping(NamedTuple):
    """What the accept/reject loop (:func:`accept_reject`) needs of a step type: its ``method`` (a
    ``tableaus.Method``, or None where the trial needs none), the row of K that holds the slope f(y_new) of a
    trial (``fsal_row``), the step-size exponent -1/(q+1) of its error estimator of order q and its largest
    growth of h per accepted step."""

    method: object
    fsal_row: int
    exponent: float
    max_factor: float


@engine_kernel(inline=True, takes_functions=True)
def rk_trial(rhs, n, stepping, control, p, arrays, work, h):
    """One trial step of an explicit method (:func:`rk_step`) of length h [s]; returns its error norm
    (:func:`error_norm`). ``work`` is unused (the Rosenbrock trial's arrays)."""
    method = stepping.method
    y, f, K, y_new, tmp = arrays
    rk_step(rhs, y, f, h, n, method.A, method.n_stages, K, y_new, tmp, p)
    return error_norm(K, method.E, method.err_mode, method.n_stages, h, y, y_new, control.n_err, control.rtol,
                      control.atol)


@engine_kernel(inline=True, takes_functions=True)
def accept_reject(trial, rhs, n, stepping, control, p, arrays, work, t, h, after_reject, budget):
    """Try steps from (t, y), slope f = rhs(y), first trial step h [s], until one is accepted: the one
    accept/reject loop of both step types.

    ``trial(rhs, n, stepping, control, p, arrays, work, h)`` takes one trial step of length h into
    ``arrays.y_new`` (and its slope f(y_new) into K[stepping.fsal_row]) and returns its error norm
    (:func:`rk_trial`, ``rosenbrock.rodas_trial``); ``stepping``: a :class:`Stepping`; ``control``: a
    :class:`Control`; ``arrays``: the :class:`Arrays` of the step; ``n``: the number of components. A trial
    is rejected when its error norm exceeds 1 (the step shrinks by ``step_factor``) or when anything in it
    is not finite (the step shrinks by MIN_FACTOR, at most MAX_NONFINITE_RETRIES times in a row). The step
    never passes t_end. Returns (code, h_taken, h_next, attempts, last): code ACCEPTED (y_new and the stages
    hold the step), BUDGET_SPENT (``budget`` attempts made), UNDERFLOW (h below ``min_step(t)``) or
    NON_FINITE; ``last`` says the step ends at t_end.
    """
    t_end = control.t_end
    y_new = arrays.y_new
    K = arrays.K
    fsal_row = stepping.fsal_row
    attempts = 0
    n_bad = 0
    code = ACCEPTED
    last = False
    h_next = h
    while True:  # one exit: a loop with early tuple returns cost ~70 ns per step more
        if attempts >= budget:
            code = BUDGET_SPENT
            break
        last = h >= t_end - t
        if last:
            h = t_end - t
        if not (h >= min_step(t)):
            code = UNDERFLOW
            break
        attempts += 1
        err = trial(rhs, n, stepping, control, p, arrays, work, h)
        finite = np.isfinite(err)
        for i in range(n):
            if not np.isfinite(y_new[i]) or not np.isfinite(K[fsal_row, i]):
                finite = False
        if not finite:
            n_bad += 1
            if n_bad > MAX_NONFINITE_RETRIES:
                code = NON_FINITE
                break
            h *= MIN_FACTOR
            after_reject = True
            continue
        n_bad = 0
        if err > 1.0:
            h *= step_factor(err, stepping.exponent, after_reject, stepping.max_factor)
            after_reject = True
            continue
        h_next = h * step_factor(err, stepping.exponent, after_reject, stepping.max_factor)
        break
    if code != ACCEPTED:
        return code, h, h, attempts, False
    return code, h, h_next, attempts, last


@engine_kernel(inline=True, takes_functions=True)
def attempt(rhs, method, control, p, arrays, t, h, after_reject, budget):
    """Try explicit steps of ``method`` (the :class:`~rimroll.solver.engine.tableaus.Method` record) from
    (t, y) until one is accepted (:func:`accept_reject` with :func:`rk_trial`): on ACCEPTED y_new and K hold
    the step, K[n_stages] is f(y_new). ``control``: a :class:`Control`; ``arrays``: the :class:`Arrays`."""
    stepping = Stepping(method, method.n_stages, -1.0 / (method.error_order + 1.0), MAX_FACTOR)
    return accept_reject(rk_trial, rhs, control.n, stepping, control, p, arrays, None, t, h, after_reject, budget)
