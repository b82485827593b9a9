"""Rodas4, the L-stable Rosenbrock method of Hairer & Wanner, for the stiff slip phases.

The slipping equations (42) are stiff while the slip speed u is small: the slip angle relaxes at
|B|/|u| (~25 m/s^2 over 1e-5 m/s), so an explicit step sits at its stability limit (~1e-6 s) for
the whole of a slip. A Rosenbrock method solves a linear system with the Jacobian of the rates
in each stage instead of iterating, and being L-stable it takes steps set by accuracy alone.

Method: RODAS (order 4, embedded order 3, six stages, stiffly accurate), E. Hairer and G. Wanner,
Solving Ordinary Differential Equations II, 2nd ed., Springer 1996, Sect. IV.7, in the form of
their code ``rodas.f`` (coefficient set 1): with E = I/(h gamma) - J and stage values k_s,

    E k_s = f(y + sum_j a_sj k_j) + sum_j c_sj k_j / h,      s = 1..6,
    y_new = y + sum_j a_5j k_j + k_5 + k_6,                   error estimate k_6,

and the dense output y(theta) = y + theta (y_new - y) + theta (1 - theta) (d2 + theta d3) with
d2 = sum d_2j k_j, d3 = sum d_3j k_j (order 3). The systems are autonomous (no time derivative
term). The last component of the state is a quadrature (the cyclic angle alpha): nothing depends
on it, so E is block triangular; its block is solved by substitution and the LU factorisation
(partial pivoting, in place, no allocation) is of the other n - 1 components.

Step-size control as the explicit methods' (``stepper``) with the error exponent -1/4 and at most
a factor :data:`MAX_FACTOR` of growth per step (Hairer's ``FACR = 1/6``).
"""

from __future__ import annotations

import numpy as np

from rimroll.solver._compile import engine_kernel
from rimroll.solver.engine.stepper import ACCEPTED, Stepping, accept_reject

GAMMA = 0.25
A21 = 1.544
A31, A32 = 0.9466785280815826, 0.2557011698983284
A41, A42, A43 = 3.314825187068521, 2.896124015972201, 0.9986419139977817
A51, A52, A53, A54 = 1.221224509226641, 6.019134481288629, 12.53708332932087, -0.6878860361058950
C21 = -5.6688
C31, C32 = -2.430093356833875, -0.2063599157091915
C41, C42, C43 = -0.1073529058151375, -9.594562251023355, -20.47028614809616
C51, C52, C53, C54 = 7.496443313967647, -10.24680431464352, -33.99990352819905, 11.70890893206160
C61, C62, C63, C64, C65 = 8.083246795921522, -7.981132988064893, -31.52159432874371, 16.31930543123136, \
    -6.058818238834054
D21, D22, D23, D24, D25 = 10.12623508344586, -7.487995877610167, -34.80091861555747, -7.992771707568823, \
    1.025137723295662
D31, D32, D33, D34, D35 = -0.6762803392801253, 6.087714651680015, 16.43084320892478, 24.76722511418386, \
    -6.594389125716872
STAGE_A = np.array([
    [0.0, 0.0, 0.0, 0.0, 0.0],
    [A21, 0.0, 0.0, 0.0, 0.0],
    [A31, A32, 0.0, 0.0, 0.0],
    [A41, A42, A43, 0.0, 0.0],
    [A51, A52, A53, A54, 0.0],
    [A51, A52, A53, A54, 1.0],  # Y6 = Y5 + k5
])
"""Row s: the coefficients of k_1..k_5 in the argument of f at stage s + 1."""
STAGE_C = np.array([
    [0.0, 0.0, 0.0, 0.0, 0.0],
    [C21, 0.0, 0.0, 0.0, 0.0],
    [C31, C32, 0.0, 0.0, 0.0],
    [C41, C42, C43, 0.0, 0.0],
    [C51, C52, C53, C54, 0.0],
    [C61, C62, C63, C64, C65],
])
"""Row s: the coefficients of k_1..k_5 / h added to f at stage s + 1."""
ERROR_EXPONENT = -0.25  # the embedded estimate is of order 3
MAX_FACTOR = 6.0  # largest growth of h after an accepted step
N_ROWS = 8  # rows of the stage array: k_1..k_6, then two rows of scratch (for the Jacobian)
ROW_JAC = 6
STIFF_SWITCH = 8.0
"""A slip phase leaves the Rosenbrock steps for the explicit method when h rho < STIFF_SWITCH (h: the
next step [s], rho: the spectral radius of the Jacobian [1/s]): an explicit step is stable up to
h rho ~ 3.3 (DP5) to 6 (DOP853) and costs about a third of a Rosenbrock step, so below this the
stiffness no longer pays for the linear algebra."""
EXPLICIT_LIMIT = 2.0
"""An explicit step of a slip phase whose h rho exceeds this is near its stability limit: the phase
takes Rosenbrock steps again."""
CHECK_EVERY = 8
"""Explicit steps of a slip phase between two evaluations of the Jacobian for :data:`EXPLICIT_LIMIT`."""
POWER_ITERATIONS = 12


@engine_kernel(inline=True)
def spectral_radius(J, m, x, tmp):
    """An estimate of the spectral radius [1/s] of J[:m, :m]: the geometric mean growth of the
    power iteration over its last half (the growth of ||J^k x|| tends to the spectral radius also
    for a complex pair, where the iterates rotate); x and tmp are scratch."""
    for i in range(m):
        x[i] = 1.0 + 0.37 * i - 0.05 * i * i  # no special direction
    log_growth = 0.0
    for k in range(POWER_ITERATIONS):
        norm = 0.0
        for i in range(m):
            acc = 0.0
            for c in range(m):
                acc += J[i, c] * x[c]
            tmp[i] = acc
            norm += acc * acc
        norm = np.sqrt(norm)
        if not (norm > 0.0 and norm < np.inf):
            return 0.0 if norm == 0.0 else np.inf
        if k >= POWER_ITERATIONS // 2:
            log_growth += np.log(norm)
        for i in range(m):
            x[i] = tmp[i] / norm
    return np.exp(log_growth / (POWER_ITERATIONS - POWER_ITERATIONS // 2))


@engine_kernel(inline=True)
def lu_factor(J, h, m, LU, piv):
    """LU = I/(h gamma) - J[:m, :m] factored in place with partial pivoting (row swaps in ``piv``).
    False if a pivot is zero or not finite (the trial step is then cut)."""
    fac = 1.0 / (h * GAMMA)
    for i in range(m):
        for c in range(m):
            LU[i, c] = -J[i, c]
        LU[i, i] += fac
    for k in range(m):
        p = k
        big = abs(LU[k, k])
        for i in range(k + 1, m):
            if abs(LU[i, k]) > big:
                big = abs(LU[i, k])
                p = i
        if not (big > 0.0 and big < np.inf):
            return False
        piv[k] = p
        if p != k:
            for c in range(m):
                tmp = LU[k, c]
                LU[k, c] = LU[p, c]
                LU[p, c] = tmp
        inv = 1.0 / LU[k, k]
        for i in range(k + 1, m):
            lik = LU[i, k] * inv
            LU[i, k] = lik
            if lik != 0.0:
                for c in range(k + 1, m):
                    LU[i, c] -= lik * LU[k, c]
    return True


@engine_kernel(inline=True)
def stage_solve(LU, piv, J, h, n, b):
    """b <- E^-1 b for E = I/(h gamma) - J, the first n - 1 components through the factors of
    :func:`lu_factor`, the last (a quadrature: column n - 1 of J is zero) by substitution."""
    m = n - 1
    for k in range(m):
        p = piv[k]
        if p != k:
            tmp = b[k]
            b[k] = b[p]
            b[p] = tmp
    for k in range(m):
        for i in range(k + 1, m):
            b[i] -= LU[i, k] * b[k]
    for i in range(m - 1, -1, -1):
        acc = b[i]
        for c in range(i + 1, m):
            acc -= LU[i, c] * b[c]
        b[i] = acc / LU[i, i]
    acc = b[m]
    for c in range(m):
        acc += J[m, c] * b[c]
    b[m] = h * GAMMA * acc


@engine_kernel(inline=True, takes_functions=True)
def stage(rhs, s, y, h, n, model, R, LU, piv, J, tmp):
    """Stage s + 1 of the step: k = E^-1 (f(y + sum_j a_sj k_j) + sum_j c_sj k_j / h) into R[s], with
    the coefficients of row s of :data:`STAGE_A` and :data:`STAGE_C`; tmp keeps the argument of f."""
    for i in range(n):
        acc = y[i]
        for j in range(s):
            acc += STAGE_A[s, j] * R[j, i]
        tmp[i] = acc
    rhs(tmp, model, R, s)
    inv_h = 1.0 / h
    for i in range(n):
        acc = 0.0
        for j in range(s):
            acc += STAGE_C[s, j] * R[j, i]
        R[s, i] += acc * inv_h
    stage_solve(LU, piv, J, h, n, R[s])


@engine_kernel(inline=True, takes_functions=True)
def rodas_step(rhs, y, f, h, n, model, R, J, LU, piv, y_new, tmp):
    """One Rodas4 step of length h [s] from y with slope f and Jacobian J: the stages into R[0..5]
    (R[5] is the error estimate) and the new state into y_new. False if E is singular."""
    if not lu_factor(J, h, n - 1, LU, piv):
        return False
    for i in range(n):
        R[0, i] = f[i]
    stage_solve(LU, piv, J, h, n, R[0])
    for s in range(1, 6):
        stage(rhs, s, y, h, n, model, R, LU, piv, J, tmp)
    for i in range(n):
        y_new[i] = tmp[i] + R[5, i]
    return True


@engine_kernel(inline=True)
def error_norm(R, y, y_new, n_err, rtol, atol):
    """RMS over the first n_err components of the error estimate k_6 scaled by
    atol[i] + rtol * max(|y_i|, |y_new_i|); the step is accepted when it is <= 1."""
    acc = 0.0
    for i in range(n_err):
        e = R[5, i] / (atol[i] + rtol * max(abs(y[i]), abs(y_new[i])))
        acc += e * e
    return np.sqrt(acc / n_err)


@engine_kernel(inline=True)
def dense_coefficients(R, y, y_new, h, n, Q):
    """The dense output of the accepted step as the engine's Q: y(theta) = y + h sum_q Q[:, q]
    theta^(q+1) (``stepper.dense_eval``), from Rodas' y + theta dy + theta (1 - theta)(d2 + theta d3)."""
    for i in range(n):
        d2 = D21 * R[0, i] + D22 * R[1, i] + D23 * R[2, i] + D24 * R[3, i] + D25 * R[4, i]
        d3 = D31 * R[0, i] + D32 * R[1, i] + D33 * R[2, i] + D34 * R[3, i] + D35 * R[4, i]
        Q[i, 0] = (y_new[i] - y[i] + d2) / h
        Q[i, 1] = (d3 - d2) / h
        Q[i, 2] = -d3 / h
        for q in range(3, Q.shape[1]):
            Q[i, q] = 0.0


@engine_kernel(inline=True, takes_functions=True)
def rodas_trial(rhs, n, stepping, control, model, arrays, work, h):
    """One trial Rodas4 step of length h [s] (:func:`rodas_step`, stages in work.R) and the slope of its end
    into K[stepping.fsal_row]; returns its error norm (:func:`error_norm`), inf where E is singular."""
    y, f, K, y_new, tmp = arrays
    if not rodas_step(rhs, y, f, h, n, model, work.R, work.J, work.LU, work.piv, y_new, tmp):
        return np.inf
    rhs(y_new, model, K, stepping.fsal_row)
    return error_norm(work.R, y, y_new, control.n_err, control.rtol, control.atol)


@engine_kernel(takes_functions=True)  # not inlined: one compiled copy, called once per step (the compile stays small)
def attempt(rhs, n, control, model, arrays, work, fsal_row, t, h, after_reject, budget):
    """Try Rodas4 steps from (t, y), slope f, Jacobian work.J at y, first trial step h [s], until one
    is accepted: ``stepper.accept_reject`` with :func:`rodas_trial` (same codes and returns). ``n``: the
    number of components (a compile-time constant where the caller can make it one: the loops then unroll);
    ``work``: the stages R (N_ROWS, n), the Jacobian J and LU (n, n), the pivots piv and the dense
    output Q (n, >= 3) (``kernels.Work``). On ACCEPTED, y_new holds the step's end, K[fsal_row] its
    slope f(y_new) (where the explicit methods keep theirs) and Q the dense output (no
    ``stepper.dense_prepare`` needed)."""
    stepping = Stepping(None, fsal_row, ERROR_EXPONENT, MAX_FACTOR)
    code, h, h_next, attempts, last = accept_reject(rodas_trial, rhs, n, stepping, control, model, arrays, work, t,
                                                    h, after_reject, budget)
    if code == ACCEPTED:
        dense_coefficients(work.R, arrays.y, arrays.y_new, h, n, work.Q)
    return code, h, h_next, attempts, last
