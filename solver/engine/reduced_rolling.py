"""Exact rolling: one leg of a conservative rolling motion on its level (the reduction of Sect. 4.4).

In the conservative rolling model (mu = inf, k_r = k_d = 0, no load) omega2_dot and omega3_dot
are proportional to omega1 and beta_dot = (r/rho) omega1, so the spins obey the linear equation
(62) in beta: z(beta) = Phi(beta) P, P = (P_I, P_II) the conserved quantities (68). With the
energy (60) conserved, omega1^2 = W(beta) and F2/m = F(beta) are fixed functions of beta on the
level (``solver.engine.reduced_tables``). The ball moves monotonically in beta until F reaches 0
(it leaves the rim) or W does (a turning point), and

    t = (rho/r) int dbeta / sqrt(W),   alpha = -(rho/R) int omega3 / ((1 - x cos beta) sqrt(W)) dbeta.

This module computes one such **leg** per job: from beta0 in the direction d (+-1) to the first
event (a turning point, a fall, or a given stop), its time, its angle alpha and the smallest F on
the way. ``solver.engine.reduced_simulate`` puts the legs together into outcomes (periodic
rolling, falls, on the rim at t_max) by the rules of docs/outcome-engine.md.

**Per panel of the table** the level's series of W, F and G = omega3 / (1 - x cos beta) are
combined once (N_COEF coefficients each, local variable u in [-1, 1]), with their derivatives and
two bounds: the lower bound c_0 - sum_{n>=1} |c_n| of a Chebyshev series (|T_n| <= 1), and the
Markov bound sum |c_n| n^2 (n^2 - 1)/3 of its second derivative.

**The first zero is found provably** (up to the table's rounding, ~1e-16 of |z|^2). A panel whose
lower bounds of W and F are both positive holds no event: the leg crosses it whole, and its time
is a 15-point Gauss-Kronrod sum over values tabled at the nodes (``reduced_tables.Table.nodes``:
five multiplications and a square root per node), accepted when the embedded 7-point Gauss sum
agrees to ``QUAD_RTOL`` (else the adaptive quadrature below). In any other panel the leg marches
over intervals [s_a, s_a + h] with values f and slopes f' at both ends; with |f''| <= M,

* f > 0 on the interval if f_a >= 0, f_b > 0, f_a + f'_a h/2 - M h^2/8 > 0 and
  f_b - f'_b h/2 - M h^2/8 > 0 (the concave lower bounds from each end, each on its half);
* f has exactly one zero there if f_a > 0 >= f_b and (f'_a + f'_b + M h)/2 < 0 (f' < 0 throughout),
  located by safeguarded Newton-bisection to adjacent floating-point numbers.

Otherwise h is halved, down to ``H_MIN`` rad, where a dip of depth M H_MIN^2/8 (~1e-26 M) is
below the table's rounding and is passed; an interval found clear doubles h.

**Turning points.** At a simple root beta_t of W the integrand has a 1/sqrt singularity. The
substitution beta = beta_t -/+ L (1 - cos theta) (both ends: beta = mid - (L/2) cos theta) makes it
smooth; W there is computed as a difference from the end (the recurrence of the Chebyshev
differences T_n(u + du) - T_n(u)), so its rounding is relative to itself, and the level through
the computed root is used (an energy change of ~1e-16). Adaptive Gauss-Kronrod (15 nodes, an
interval accepted when its 7-point Gauss sum agrees to ``QUAD_RTOL`` of the segment's first
estimate) resolves near-saddle passages. Every loop has a hard cap (status ``max_steps``).

The same algorithm is written in C (``solver/engine/_exact_legs.c``), compiled when rimroll is installed and
run by ``reduced_legs`` through ``reduced_compiled``; this numba kernel runs where that library is missing (an
install without a C compiler), compiled on first use. tests/solver/engine/test_exact_legs_c.py keeps the two
equal; docs/explanation/exact-rolling.md measures both.
"""

from __future__ import annotations

import math

from rimroll.solver import _jit
from rimroll.solver._compile import engine_kernel as kernel
from rimroll.solver.engine.reduced_tables import G21, G22, N_COEF, N_NODES, Q11, Q12, Q22, S11, S12, S22, SIN

H_MIN = 1e-13
"""Shortest interval of the root isolation [rad]."""
MAX_MARCH = 4_000
"""Most intervals of the root isolation in one panel."""
MAX_STACK = 400
"""Most pending intervals of one adaptive quadrature."""
MAX_QUAD = 4_000
"""Most intervals of one adaptive quadrature."""
QUAD_RTOL = 1e-10
"""An interval's 15-point Gauss-Kronrod sum is accepted when the embedded 7-point Gauss sum agrees with it
to this fraction of the segment's integral: the Kronrod sum's own error is then far smaller (for an
analytic integrand ~(1e-10)^(23/14) ~ 4e-17, relative)."""
MAX_NEWTON = 100
"""Most iterations of a root search."""
NEAR = 1.0
"""A segment with no turning point at its ends whose W, extrapolated linearly from an end, vanishes within NEAR
times its length beyond that end (a turning point just outside: 1/sqrt(W) nearly singular there) is integrated
in theta^2 = distance from that zero (modes 4, 5 of ``_gk``): the Gauss-Kronrod sum then converges as for a
smooth integrand (on the Fig. 11 section the first sum of 90% of such segments failed before, 15% now)."""


def _helper(func):
    """Compile a helper of the leg kernel: as ``solver._compile.engine_kernel`` (nopython, nogil, cached on disk,
    numpy error model, no reference counting: the helpers allocate nothing) and without the CPython and cfunc
    wrappers, which only a call from Python needs; ``RIMROLL_NO_JIT=1``: the Python source."""
    if _jit._DISABLE:
        func.py_func = func
        return func
    return _jit.njit_cached(func, nogil=True, error_model="numpy", no_cpython_wrapper=True, no_cfunc_wrapper=True,
                            **_jit.NO_REFCOUNT)


# constants vector c
C_A, C_R2RHO, C_R2R, C_G, C_TIME, C_ALPHA, C_BLO, C_W, C_NPAN = range(9)
N_C = 9
# a job row: start beta [rad], direction (+-1), 1 if W = 0 at the start, stop beta [rad] (+-inf: none),
# the level C0 [1/s^2], q0 = P1^2, q1 = 2 P1 P2, q2 = P2^2 [1/s^2], P1, P2 [1/s]
J_BETA, J_DIR, J_SING, J_STOP, J_C0, J_Q0, J_Q1, J_Q2, J_P1, J_P2 = range(10)
N_J = 10
# an output row: event kind, beta there [rad], time [s], alpha [rad], smallest F2/m [m/s^2], evaluations,
# 1 if every quadrature met its tolerance within its caps, beta of the smallest F [rad]
O_KIND, O_BETA, O_T, O_ALPHA, O_FMIN, O_EVALS, O_OK, O_BMIN = range(8)
N_O = 8
# event kinds
EV_TURN, EV_FALL, EV_STOP, EV_FAIL, EV_CAP, EV_NONE = 0, 1, 2, 3, 4, 5
# rows of the per-thread work array (N_WORK, N_COEF): the level's series on the current panel
W_C, W_D, F_C, F_D, G_C, KEY = range(6)
N_WORK = 6
# KEY row: panel index, Markov bounds of W'' and F'' (in u), lower bounds of W and F on the panel
K_PANEL, K_MW, K_MF, K_LW, K_LF = range(5)
# rows of the quadrature rule (``reduced_legs.RULE``): nodes, Kronrod and Gauss weights on [-1, 1]; sin theta and
# sin(theta/2) at the nodes mapped to [0, pi/2]; sin theta, sin(theta/2), cos(theta/2) mapped to [0, pi]
R_NODES, R_KRONROD, R_GAUSS, R_SIN_QUARTER, R_SIN_HALF = 0, 1, 2, 3, 5
N_RULE = 8
# node table rows (reduced_tables.NODE_FUNCTIONS order)
N_SIN, N_Q11, N_Q12, N_Q22, N_S11, N_S12, N_S22, N_G21, N_G22 = range(9)


@_helper
def _panel(beta, d, c):
    """Index of the panel holding beta (on an edge: the panel ahead in the direction d), or -1 outside."""
    y = (beta - c[C_BLO]) / c[C_W]
    i = math.floor(y)
    if d < 0 and y == i:
        i -= 1
    if i < 0 or i >= int(c[C_NPAN]):
        return -1
    return i


@_helper
def _u(beta, i, c):
    """Local variable u in [-1, 1] of beta on panel i."""
    return 2.0 * ((beta - c[C_BLO]) / c[C_W] - i) - 1.0


@_helper
def _see_f(f, beta, out):
    """Lowers out[O_FMIN] to f [m/s^2] (seen at beta [rad], kept in out[O_BMIN])."""
    if f < out[O_FMIN]:
        out[O_FMIN] = f
        out[O_BMIN] = beta


@_helper
def _derivative(src, dst):
    """Chebyshev coefficients of d/du of the series src (N_COEF) into dst."""
    b2 = 0.0
    b1 = 0.0
    for k in range(N_COEF - 2, -1, -1):
        dk = b2 + 2.0 * (k + 1) * src[k + 1]
        dst[k] = dk
        b2 = b1
        b1 = dk
    dst[N_COEF - 1] = 0.0
    dst[0] *= 0.5


@_helper
def _combine(i, job, tab, c, work):
    """The level's series of W [1/s^2], F [m/s^2], G on panel i (and their d/du, bounds) into ``work``."""
    if work[KEY, K_PANEL] == i:
        return
    v = tab[i]
    q0 = job[J_Q0]
    q1 = job[J_Q1]
    q2 = job[J_Q2]
    mw = 0.0
    mf = 0.0
    lw = 0.0
    lf = 0.0
    for n in range(N_COEF):
        wn = -c[C_A] * v[SIN, n] - (q0 * v[Q11, n] + q1 * v[Q12, n] + q2 * v[Q22, n])
        if n == 0:
            wn += job[J_C0]
        fn = c[C_R2R] * (q0 * v[S11, n] + q1 * v[S12, n] + q2 * v[S22, n]) - c[C_R2RHO] * wn + c[C_G] * v[SIN, n]
        work[W_C, n] = wn
        work[F_C, n] = fn
        work[G_C, n] = job[J_P1] * v[G21, n] + job[J_P2] * v[G22, n]
        markov = n * n * (n * n - 1.0) / 3.0
        mw += abs(wn) * markov
        mf += abs(fn) * markov
        if n > 0:
            lw += abs(wn)
            lf += abs(fn)
    _derivative(work[W_C], work[W_D])
    _derivative(work[F_C], work[F_D])
    work[KEY, K_PANEL] = i
    work[KEY, K_MW] = mw * (1.0 + 1e-12)
    work[KEY, K_MF] = mf * (1.0 + 1e-12)
    work[KEY, K_LW] = work[W_C, 0] - lw * (1.0 + 1e-12)
    work[KEY, K_LF] = work[F_C, 0] - lf * (1.0 + 1e-12)


@_helper
def _values(u, work, scale):
    """(W, dW/dbeta, F, dF/dbeta) at u of the combined panel (scale = 2/width [1/rad]): one Chebyshev
    recurrence over the four series."""
    t0 = 1.0
    t1 = u
    w = work[W_C, 0] + work[W_C, 1] * u
    dw = work[W_D, 0] + work[W_D, 1] * u
    f = work[F_C, 0] + work[F_C, 1] * u
    df = work[F_D, 0] + work[F_D, 1] * u
    for n in range(2, N_COEF):
        t2 = 2.0 * u * t1 - t0
        w += work[W_C, n] * t2
        dw += work[W_D, n] * t2
        f += work[F_C, n] * t2
        df += work[F_D, n] * t2
        t0 = t1
        t1 = t2
    return w, dw * scale, f, df * scale


@_helper
def _classify(fa, ga, fb, gb, m2, h):
    """0: f > 0 on the interval (h long, slopes ga, gb along it, |f''| <= m2); 1: exactly one zero;
    2: undecided."""
    q = m2 * h * h / 8.0
    if fa >= 0.0 and fb > 0.0 and fa + 0.5 * ga * h - q > 0.0 and fb - 0.5 * gb * h - q > 0.0:
        return 0
    if fa > 0.0 and fb <= 0.0 and ga + gb + m2 * h < 0.0:
        return 1
    return 2


@_helper
def _root(beta_a, d, h, which, i, work, c):
    """Zero of W (which = 0) or F (1) at distance s in [0, h] from beta_a in direction d on panel i, where the
    value is > 0 at s = 0 and <= 0 at s = h: safeguarded Newton-bisection until the bracket is within the
    resolution of the panel's local variable (4e-16 (|beta_a| + h + width) rad: beta steps below it no longer
    change u). Returns (beta [rad] of the bracket's end where the value is <= 0, evaluations)."""
    scale = 2.0 / c[C_W]
    tol = 4e-16 * (abs(beta_a) + h + c[C_W])
    lo = 0.0
    hi = h
    s = 0.5 * h
    n = 0
    for _ in range(MAX_NEWTON):
        W, dW, F, dF = _values(_u(beta_a + d * s, i, c), work, scale)
        n += 1
        f = W if which == 0 else F
        g = d * (dW if which == 0 else dF)
        if f > 0.0:
            lo = s
        else:
            hi = s
        if hi - lo <= 2.0 * tol:
            break
        s_new = s - f / g if g != 0.0 else 0.5 * (lo + hi)
        if abs(s_new - s) < tol:  # converged to within the resolution: close the bracket from the zero's side
            s_new = s + tol if f > 0.0 else s - tol
        if not (lo < s_new < hi):
            s_new = 0.5 * (lo + hi)
        s = s_new
    return beta_a + d * hi, n


@_helper
def _isolate(beta_a, beta_end, d, i, sing, work, c, out):
    """The first zero of W or F from beta_a towards beta_end (direction d) on panel i: (kind EV_TURN, EV_FALL or
    EV_NONE, its beta [rad], evaluations). Lowers out[O_FMIN] to the values of F it sees. sing: W = 0 at beta_a."""
    scale = 2.0 / c[C_W]
    mw = work[KEY, K_MW] * scale * scale
    mf = work[KEY, K_MF] * scale * scale
    Wa, dWa, Fa, dFa = _values(_u(beta_a, i, c), work, scale)
    if sing:
        Wa = 0.0
    ga_w = d * dWa
    ga_f = d * dFa
    length = d * (beta_end - beta_a)
    pos = 0.0
    h = length
    n = 1
    for _ in range(MAX_MARCH):
        if pos >= length:
            return EV_NONE, beta_end, n
        hh = min(h, length - pos)
        beta_b = beta_a + d * hh if pos + hh < length else beta_end
        hh = d * (beta_b - beta_a)
        Wb, dWb, Fb, dFb = _values(_u(beta_b, i, c), work, scale)
        n += 1
        gb_w = d * dWb
        gb_f = d * dFb
        kw = _classify(Wa, ga_w, Wb, gb_w, mw, hh)
        kf = _classify(Fa, ga_f, Fb, gb_f, mf, hh)
        passed = kw == 0 and kf == 0
        if not passed and (kw != 2 and kf != 2 or hh <= H_MIN):
            bw = math.inf
            bf = math.inf
            if kw == 1 or (kw == 2 and Wb <= 0.0 < Wa):
                rw, m = _root(beta_a, d, hh, 0, i, work, c)
                n += m
                bw = d * (rw - beta_a)
            if kf == 1 or (kf == 2 and Fb <= 0.0 < Fa):
                rf, m = _root(beta_a, d, hh, 1, i, work, c)
                n += m
                bf = d * (rf - beta_a)
            if bf < math.inf and bf <= bw:
                _see_f(0.0, beta_a + d * bf, out)
                return EV_FALL, beta_a + d * bf, n
            if bw < math.inf:
                return EV_TURN, beta_a + d * bw, n
            if Fa <= 0.0:  # F2 = 0 at the start, falling
                _see_f(Fa, beta_a, out)
                return EV_FALL, beta_a, n
            if Wa <= 0.0 and not sing:
                return EV_TURN, beta_a, n
            passed = True  # a touch below the resolution
        if passed:
            _see_f(Fb, beta_b, out)
            pos += hh
            beta_a, Wa, ga_w, Fa, ga_f = beta_b, Wb, gb_w, Fb, gb_f
            sing = False
            h = 2.0 * hh
        else:
            h = 0.5 * hh
    return EV_CAP, beta_a, n


@_helper
def _w_g(work, u0, du, difference):
    """(W(u0 + du) - W(u0) if difference else W(u0 + du), G(u0 + du)) on the combined panel, in one pass: the forward
    recurrences of T_n(u0) and of the differences D_n = T_n(u0 + du) - T_n(u0), so that the difference of W is
    accurate relative to itself for small du."""
    u = u0 + du
    t_prev = 1.0
    t_cur = u0
    d_prev = 0.0
    d_cur = du
    w = work[W_C, 1] * du if difference else work[W_C, 0] + work[W_C, 1] * u
    g = work[G_C, 0] + work[G_C, 1] * u
    for n in range(1, N_COEF - 1):
        d_next = 2.0 * u * d_cur + 2.0 * du * t_cur - d_prev
        t_next = 2.0 * u0 * t_cur - t_prev
        w += work[W_C, n + 1] * (d_next if difference else t_next + d_next)
        g += work[G_C, n + 1] * (t_next + d_next)
        d_prev = d_cur
        d_cur = d_next
        t_prev = t_cur
        t_cur = t_next
    return w, g


@_helper
def _clear(i, job, tab, spread, c):
    """Whether W > 0 and F > 0 on the whole panel i, by a bound that needs no combined series: W's c_0 minus the
    spreads of its terms (``reduced_tables.Table.spread``), and likewise F's."""
    v = tab[i]
    sp = spread[i]
    q0 = job[J_Q0]
    q1 = job[J_Q1]
    q2 = job[J_Q2]
    aq1 = abs(q1)
    w0 = job[J_C0] - c[C_A] * v[SIN, 0] - (q0 * v[Q11, 0] + q1 * v[Q12, 0] + q2 * v[Q22, 0])
    sq = q0 * sp[1] + aq1 * sp[2] + q2 * sp[3]
    if not w0 - (c[C_A] * sp[0] + sq) > 0.0:
        return False
    f0 = c[C_R2R] * (q0 * v[S11, 0] + q1 * v[S12, 0] + q2 * v[S22, 0]) - c[C_R2RHO] * w0 + c[C_G] * v[SIN, 0]
    sf = c[C_R2R] * (q0 * sp[4] + aq1 * sp[5] + q2 * sp[6]) + c[C_R2RHO] * sq + (c[C_R2RHO] * c[C_A] + c[C_G]) * sp[0]
    return f0 - sf > 0.0


@_helper
def _full_panel(i, job, nod, c, rule, out):
    """Time [s] and alpha [rad] across the whole panel i by the tabled Gauss-Kronrod rule (rule: nodes,
    Kronrod weights, Gauss weights); (t, alpha, ok): ok when the Gauss sum agrees to QUAD_RTOL. Lowers
    out[O_FMIN] to F [m/s^2] at the nodes."""
    v = nod[i]
    q0 = job[J_Q0]
    q1 = job[J_Q1]
    q2 = job[J_Q2]
    k = 0.0
    g = 0.0
    a = 0.0
    for m in range(N_NODES):
        w = job[J_C0] - c[C_A] * v[N_SIN, m] - (q0 * v[N_Q11, m] + q1 * v[N_Q12, m] + q2 * v[N_Q22, m])
        if not w > 0.0:
            return 0.0, 0.0, False
        inv = 1.0 / math.sqrt(w)
        k += rule[1, m] * inv
        g += rule[2, m] * inv
        a += rule[1, m] * inv * (job[J_P1] * v[N_G21, m] + job[J_P2] * v[N_G22, m])
        f = c[C_R2R] * (q0 * v[N_S11, m] + q1 * v[N_S12, m] + q2 * v[N_S22, m]) - c[C_R2RHO] * w + c[C_G] * v[N_SIN, m]
        if f < out[O_FMIN]:
            out[O_FMIN] = f
            out[O_BMIN] = c[C_BLO] + (i + 0.5 * (rule[0, m] + 1.0)) * c[C_W]
    half = 0.5 * c[C_W]
    return c[C_TIME] * k * half, -c[C_ALPHA] * a * half, abs(k - g) <= QUAD_RTOL * k


@_helper
def _node_f(i, lo, hi, job, nod, c, rule, out):
    """Lowers out[O_FMIN] to F [m/s^2] at the tabled nodes of panel i within [lo, hi] [rad]."""
    v = nod[i]
    q0 = job[J_Q0]
    q1 = job[J_Q1]
    q2 = job[J_Q2]
    for m in range(N_NODES):
        b = c[C_BLO] + (i + 0.5 * (rule[0, m] + 1.0)) * c[C_W]
        if lo <= b <= hi:
            w = job[J_C0] - c[C_A] * v[N_SIN, m] - (q0 * v[N_Q11, m] + q1 * v[N_Q12, m] + q2 * v[N_Q22, m])
            _see_f(c[C_R2R] * (q0 * v[N_S11, m] + q1 * v[N_S12, m] + q2 * v[N_S22, m]) - c[C_R2RHO] * w
                   + c[C_G] * v[N_SIN, m], b, out)


@_helper
def _gk(th_a, th_b, beta_s, beta_e, mode, ws, we, near, i, work, c, rule):
    """15-point Gauss-Kronrod and 7-point Gauss sums over theta in [th_a, th_b] of dt/dtheta, and the Kronrod
    sum of dalpha/dtheta, on panel i. mode 0: beta = beta_s + (beta_e - beta_s) theta; 1 (W = 0 at beta_s):
    beta = beta_s + L (1 - cos theta); 2 (W = 0 at beta_e): beta = beta_e - L (1 - cos theta), theta in
    [0, pi/2]; 3 (both): beta = mid - (L/2) cos theta, theta in [0, pi]; 4 (W's zero ``near`` rad behind
    beta_s): |beta - beta_s| = theta^2 - near; 5 (``near`` rad beyond beta_e): |beta_e - beta| = theta^2 - near,
    theta in [sqrt(near), sqrt(|L| + near)]. ws, we: W computed at the ends."""
    half = 0.5 * (th_b - th_a)
    mid = 0.5 * (th_a + th_b)
    L = beta_e - beta_s
    aL = abs(L)
    du_db = 2.0 / c[C_W]
    slope = (we - ws) / L if mode == 3 else 0.0
    k = 0.0
    g = 0.0
    a = 0.0
    u_s = _u(beta_s, i, c)
    u_e = _u(beta_e, i, c)
    # the whole range of theta: its sines are tabled in rule (rows R_SIN_QUARTER.. for [0, pi/2], R_SIN_HALF.. [0, pi])
    row = -1
    if th_a == 0.0 and (mode == 1 or mode == 2) and th_b == 0.5 * math.pi:
        row = R_SIN_QUARTER
    elif th_a == 0.0 and mode == 3 and th_b == math.pi:
        row = R_SIN_HALF
    for m in range(N_NODES):
        th = mid + half * rule[0, m]
        if mode == 0:
            ref = beta_s
            delta = L * th
            jac = aL
        elif mode >= 4:  # theta^2 = near + the distance from the end next to W's zero
            ref = beta_s if mode == 4 else beta_e
            delta = th * th - near if (mode == 4) == (L > 0.0) else near - th * th
            jac = 2.0 * th
        else:
            if row >= 0:
                sh = rule[row + 1, m]
                jac = aL * rule[row, m]
            else:
                sh = math.sin(0.5 * th)
                jac = aL * math.sin(th)
            if mode == 1:
                ref = beta_s
                delta = 2.0 * L * sh * sh
            elif mode == 2:
                ref = beta_e
                delta = -2.0 * L * sh * sh
            elif th <= 0.5 * math.pi:
                ref = beta_s
                delta = L * sh * sh
                jac *= 0.5
            else:
                ch = rule[R_SIN_HALF + 2, m] if row >= 0 else math.cos(0.5 * th)
                ref = beta_e
                delta = -L * ch * ch
                jac *= 0.5
        w, gv = _w_g(work, u_s if ref == beta_s else u_e, delta * du_db, 1 <= mode <= 3)
        if mode == 3:
            w -= slope * delta
        if w > 0.0:
            inv = jac / math.sqrt(w)
            k += rule[1, m] * inv
            g += rule[2, m] * inv
            a += rule[1, m] * inv * gv
    return k * half, g * half, a * half


@_helper
def _segment(beta_s, beta_e, sing_s, sing_e, i, work, c, rule, stack):
    """Time [s] and alpha [rad] from beta_s to beta_e on panel i (monotone motion; W = 0 at the ends flagged):
    adaptive Gauss-Kronrod. Returns (t, alpha, ok, evaluations)."""
    if beta_e == beta_s:
        return 0.0, 0.0, True, 0
    mode = (1 if sing_s else 0) + (2 if sing_e else 0)
    scale = 2.0 / c[C_W]
    ws = 0.0
    we = 0.0
    near = 0.0
    n_ev = 0
    if mode == 3 or mode == 0:
        ws, dws, _, _ = _values(_u(beta_s, i, c), work, scale)
        we, dwe, _, _ = _values(_u(beta_e, i, c), work, scale)
        n_ev = 2
        if mode == 0:  # W's zero by linear extrapolation, behind the start or beyond the end, nearer than the length
            dd = 1.0 if beta_e > beta_s else -1.0
            length = abs(beta_e - beta_s)
            near_s = ws / (dd * dws) if dd * dws > 0.0 else math.inf
            near_e = we / (-dd * dwe) if dd * dwe < 0.0 else math.inf
            if near_s < NEAR * length and near_s <= near_e and ws > 0.0:
                mode = 4
                near = near_s
            elif near_e < NEAR * length and we > 0.0:
                mode = 5
                near = near_e
    top = math.pi if mode == 3 else (0.5 * math.pi if mode == 1 or mode == 2 else 1.0)
    bottom = 0.0
    if mode >= 4:
        bottom = math.sqrt(near)
        top = math.sqrt(abs(beta_e - beta_s) + near)
    k, g, a = _gk(bottom, top, beta_s, beta_e, mode, ws, we, near, i, work, c, rule)
    n_ev += N_NODES
    if abs(k - g) <= QUAD_RTOL * abs(k):
        return c[C_TIME] * k, -c[C_ALPHA] * a, True, n_ev
    tol = QUAD_RTOL * abs(k)
    stack[0, 0] = bottom
    stack[0, 1] = top
    n_st = 1
    k_sum = 0.0
    a_sum = 0.0
    for _ in range(MAX_QUAD):
        if n_st == 0:
            return c[C_TIME] * k_sum, -c[C_ALPHA] * a_sum, True, n_ev
        n_st -= 1
        lo = stack[n_st, 0]
        hi = stack[n_st, 1]
        m = 0.5 * (lo + hi)
        for side in range(2):
            x0 = lo if side == 0 else m
            x1 = m if side == 0 else hi
            k, g, a = _gk(x0, x1, beta_s, beta_e, mode, ws, we, near, i, work, c, rule)
            n_ev += N_NODES
            if abs(k - g) <= tol or x1 - x0 < 1e-14 * (top - bottom):
                k_sum += k
                a_sum += a
            elif n_st >= stack.shape[0]:
                return c[C_TIME] * k_sum, -c[C_ALPHA] * a_sum, False, n_ev
            else:
                stack[n_st, 0] = x0
                stack[n_st, 1] = x1
                n_st += 1
    return c[C_TIME] * k_sum, -c[C_ALPHA] * a_sum, False, n_ev


@_helper
def _slope_f(beta, job, tab, c, work):
    """dF/dbeta [m/s^2/rad] at beta [rad] (combining its panel's series if needed)."""
    i = _panel(beta, 1.0, c)
    _combine(i, job, tab, c, work)
    return _values(_u(beta, i, c), work, 2.0 / c[C_W])


@_helper
def _refine_min(beta, lo, hi, job, tab, c, work, out):
    """Lowers out[O_FMIN] to the minimum of F near beta: the zero of dF/dbeta bracketed within +-0.15 panel of beta,
    inside [lo, hi], by the Illinois variant of regula falsi to 1e-7 of a panel (F is then within |F''| 1e-16
    rad^2 of its minimum)."""
    a = max(beta - 0.15 * c[C_W], lo)
    b = min(beta + 0.15 * c[C_W], hi)
    ga = _slope_f(a, job, tab, c, work)[3]
    gb = _slope_f(b, job, tab, c, work)[3]
    if not (ga < 0.0 < gb):
        return
    side = 0
    m = 0.5 * (a + b)
    for _ in range(MAX_NEWTON):
        if b - a < 1e-7 * c[C_W]:
            break
        m = (a * gb - b * ga) / (gb - ga)
        if not (a < m < b):
            m = 0.5 * (a + b)
        gm = _slope_f(m, job, tab, c, work)[3]
        if gm < 0.0:
            a, ga = m, gm
            if side == -1:
                gb *= 0.5
            side = -1
        else:
            b, gb = m, gm
            if side == 1:
                ga *= 0.5
            side = 1
        if abs(gm) == 0.0 or abs(b - a) < 1e-7 * c[C_W]:
            break
    out[O_FMIN] = min(out[O_FMIN], _slope_f(m, job, tab, c, work)[2])


@_helper
def _leg(job, tab, nod, spread, c, rule, work, stack, out):
    """One leg (see the module): writes out (N_O) for the job row (N_J)."""
    beta = job[J_BETA]
    d = job[J_DIR]
    stop = job[J_STOP]
    sing = job[J_SING] > 0.0
    scale = 2.0 / c[C_W]
    work[KEY, K_PANEL] = -1.0
    out[O_FMIN] = math.inf
    out[O_BMIN] = beta
    t = 0.0
    alpha = 0.0
    ok = True
    n_ev = 0
    kind = EV_CAP
    first = True
    i = _panel(beta, d, c)
    for _ in range(int(c[C_NPAN]) + 2):
        if i < 0 or i >= int(c[C_NPAN]) or not math.isfinite(beta):
            kind = EV_FAIL
            break
        edge = c[C_BLO] + (i + 1) * c[C_W] if d > 0 else c[C_BLO] + i * c[C_W]
        at_stop = d * (stop - edge) <= 0.0
        if not first and not at_stop and _clear(i, job, tab, spread, c):  # the whole panel, no event
            tp, ap, good = _full_panel(i, job, nod, c, rule, out)
            n_ev += N_NODES
            if good:
                t += tp
                alpha += ap
                beta = edge
                i += 1 if d > 0 else -1
                continue
        _combine(i, job, tab, c, work)
        end = stop if at_stop else edge
        if first:
            _see_f(_values(_u(beta, i, c), work, scale)[2], beta, out)
            n_ev += 1
        ev = EV_NONE
        b_e = end
        if not (work[KEY, K_LW] > 0.0 and work[KEY, K_LF] > 0.0 and not (first and sing)):
            ev, b_e, m = _isolate(beta, end, d, i, first and sing, work, c, out)
            n_ev += m
            if ev == EV_CAP:
                kind = EV_CAP
                break
        good = False
        if not first and ev == EV_NONE and not at_stop:
            tp, ap, good = _full_panel(i, job, nod, c, rule, out)
            n_ev += N_NODES
        else:
            _node_f(i, min(beta, b_e), max(beta, b_e), job, nod, c, rule, out)
        if not good:
            tp, ap, good, m = _segment(beta, b_e, first and sing, ev == EV_TURN, i, work, c, rule, stack)
            n_ev += m
        t += tp
        alpha += ap
        ok = ok and good
        if ev != EV_NONE or at_stop:
            kind = ev if ev != EV_NONE else EV_STOP
            beta = b_e
            if ev != EV_FALL:
                _see_f(_values(_u(beta, i, c), work, scale)[2], beta, out)
            break
        beta = edge
        first = False
        i += 1 if d > 0 else -1
    out[O_KIND] = kind
    out[O_BETA] = beta
    out[O_T] = t
    out[O_ALPHA] = alpha
    out[O_EVALS] = n_ev
    out[O_OK] = 1.0 if ok else 0.0


@_helper
def _leg_fmin(job, tab, c, work, out):
    """Refines out[O_FMIN] of a finished leg: the smallest F sampled (at out[O_BMIN]) to the zero of dF/dbeta near
    it, within the leg's range (its start to out[O_BETA])."""
    lo = min(job[J_BETA], out[O_BETA])
    hi = max(job[J_BETA], out[O_BETA])
    if hi > lo and out[O_FMIN] > 0.0 and lo < out[O_BMIN] < hi:
        _refine_min(out[O_BMIN], lo, hi, job, tab, c, work, out)


@kernel
def legs(jobs, tab, nod, spread, c, rule, work, stack, out):
    """``_leg`` for each row of jobs (m, N_J) into out (m, N_O). tab: ``reduced_tables.Table.values``; nod: its
    ``nodes``; spread: its ``spread``; c: the constants (N_C); rule: the Gauss-Kronrod rule (3, N_NODES); work
    (N_WORK, N_COEF) and stack (MAX_STACK, 2): scratch, one per thread."""
    for n in range(jobs.shape[0]):
        _leg(jobs[n], tab, nod, spread, c, rule, work, stack, out[n])
        _leg_fmin(jobs[n], tab, c, work, out[n])
