"""Exact rolling: the conservative rolling-only scene solved by the paper's reduction (Sect. 4.4).

In the conservative rolling model (mu = inf, k_r = k_d = 0, no load) omega2_dot and omega3_dot
are proportional to omega1 and beta_dot = (r/rho) omega1, so the spins obey the linear equation
(62) in beta: z(beta) = Phi(beta) P, P = (P_I, P_II) the conserved quantities (68). With the
energy (60) conserved, omega1^2 = W(beta) and F2/m are fixed functions of beta on the level
(``solver.engine.reduced_tables``: 7 tabled functions of beta, 4 numbers per state). The motion
is a quadrature on that level: beta moves monotonically until F2 reaches 0 (the ball leaves the
rim) or W does (a turning point, where omega1 and beta_dot change sign), and

    t = (rho/r) int dbeta / sqrt(W(beta)),    alpha = -(rho/R) int omega3(beta) / ((1 - x cos beta) sqrt(W)) dbeta.

No time integration, no step-size control: the events are roots of smooth functions of one
variable, the times integrals.

**The first zero is found provably** (up to the table's rounding, ~1e-16 of |z|^2). On each
table panel the curvature of W and of F2/m is bounded by M = sum |coefficient| x (Markov bound
of the tabled form's Chebyshev polynomial) (``reduced_tables.curvature_bound``). The march from
beta0 in the direction of motion (s = distance travelled) takes intervals [s_a, s_a + h] inside
one panel with values f and slopes f' at both ends; with |f''| <= M,

* f > 0 on the interval if f_a >= 0, f_b > 0, f_a + f'_a h/2 - M h^2/8 > 0 and
  f_b - f'_b h/2 - M h^2/8 > 0 (the concave lower bounds from each end, each on its half);
* f has exactly one zero there if f_a > 0 >= f_b and (f'_a + f'_b + M h)/2 < 0 (f' < 0 throughout),
  located by safeguarded Newton-bisection to adjacent floating-point numbers.

Otherwise h is halved (the interval is retried), down to ``H_MIN`` rad: there an interval with
f > 0 at both ends can dip below zero by at most M H_MIN^2/8 (~1e-26 M, a grazing below the
table's rounding) and is passed, and one with a sign change gives its zero by bisection. An
excluded interval doubles h (up to a panel). A loop never exceeds ``MAX_MARCH`` intervals
(status ``max_steps``).

**Turning points.** W has a simple root at beta_t (omega1 reverses). The time to it is integrated
with the substitution beta = beta_t -/+ L (1 - cos theta) (both ends: beta = mid - L/2 cos theta),
which makes the integrand smooth (W ~ W'(beta_t) (beta - beta_t) ~ theta^2, dbeta ~ theta dtheta);
W there is taken minus its computed value at the root (the level through the computed root, an
energy change of ~1e-16), so the integral is finite and smooth. Adaptive Gauss-Legendre
(``GL_NODES`` nodes, each interval against its two halves, at most ``MAX_PANELS`` intervals:
status ``max_steps`` beyond) gives times to ~1e-14 relative; near a saddle (W with a near-double
root) the subdivision resolves the logarithmic peak.

**The outcome rules** (docs/outcome-engine.md, ``solver.engine.rules``) are those of ``simulate``:
F2 < 0 at the start: the ball separates at t = 0; a steady motion (``rules.on_steady_motion``):
``steady_motion`` at t = 0; F2 reaching 0: a fall, in or out by ``rules.fall_outcome``; two
transversal omega1 zeros (``rules.transversal_omega1_zero`` at the turning points, at the
simulation's rtol): ``periodic_rolling`` at the second, half_period = their time difference
(Prop. 4; a start with omega1 = 0 exactly counts as the first zero when transversal, and the ball
moves the way omega1_dot points); still on the rim at t_max (the state there by Newton on t(beta)).
Turning points that are not transversal (a near-separatrix) reverse the ball but are not counted,
as in the engine; a separatrix itself (W with a double root) is never reached within t_max.
"""

from __future__ import annotations

import numpy as np

from rimroll.solver import _jit
from rimroll.solver._compile import engine_kernel as kernel
from rimroll.solver.engine import rules
from rimroll.solver.engine.outcomes import (
    MAX_STEPS,
    NON_FINITE,
    OK,
    ON_RIM_AT_T_MAX,
    PERIODIC_ROLLING,
)
from rimroll.solver.engine.reduced_tables import N_COEF, N_FORMS, N_FUNCTIONS, PHI21, PHI22, Q11, S11

H_MIN = 1e-13
"""Shortest interval of the root isolation [rad]."""
MAX_MARCH = 20_000
"""Most intervals of one march (the first event in one direction)."""
MAX_PANELS = 4_000
"""Most intervals of one adaptive quadrature."""
QUAD_RTOL = 1e-12
"""Tolerance of each quadrature interval (its value against that of its halves), relative to the whole
leg's first estimate."""
MAX_NEWTON = 100
"""Most iterations of a root or inverse-time search."""
MAX_LEGS = 64
"""Most turning points followed when they are not transversal (then: on the rim at t_max)."""
GL_NODES = 10



def _helper(func):
    """Compile a helper of the kernel: as ``solver._compile.engine_kernel`` (nopython, nogil, cached on disk, numpy
    error model, no reference counting: the helpers allocate nothing) and without the CPython and cfunc
    wrappers, which only a call from Python needs and which cost a good part of each helper's compile;
    ``RIMROLL_NO_JIT=1``: the Python source."""
    if _jit._DISABLE:
        func.py_func = func
        return func
    return _jit.njit_cached(func, nogil=True, error_model="numpy", no_cpython_wrapper=True, no_cfunc_wrapper=True,
                            **_jit.NO_REFCOUNT)


# rows of the working table (axis 1): the tabled functions (reduced_tables.PHI11 .. S22), the slopes
# of the forms (T_SLOPES ..), then per panel the level's combined series (filled by ``_coefs``) and its key
T_SLOPES = N_FUNCTIONS
K_Q, K_DQ, K_S, K_DS, K_W2, K_W3, K_KEY = range(T_SLOPES + N_FORMS, T_SLOPES + N_FORMS + 7)
N_ROWS = K_KEY + 1

# constants vector c
C_X, C_K, C_A, C_R2RHO, C_R2R, C_G, C_TIME, C_ALPHA, C_BLO, C_W, C_NPAN, C_RTOL, C_TMAX = range(13)
N_C = 13
# per-state level vector st: C0 [1/s^2], P1, P2 [1/s]
ST_C0, ST_P1, ST_P2 = range(3)
# event kinds of a march
EV_TURN, EV_FALL, EV_FAIL, EV_CAP = 0, 1, 2, 3
# result columns of the kernel (float rows)
R_T, R_F2MIN, R_HALF, R_REV, R_BETA, R_W1, R_W2, R_W3, R_LO, R_HI, N_R = range(11)
# int rows
RI_OUTCOME, RI_STATUS, RI_EVALS, RI_FELL, N_RI = range(5)


@_helper
def _clenshaw(row, u):
    """The Chebyshev series with coefficients ``row`` (N_COEF) at u in [-1, 1]."""
    b1 = 0.0
    b2 = 0.0
    for n in range(N_COEF - 1, 0, -1):
        b0 = 2.0 * u * b1 - b2 + row[n]
        b2 = b1
        b1 = b0
    return u * b1 - b2 + row[0]


@_helper
def _panel(beta, d, c):
    """(panel index, local u) of beta; on a panel edge the panel ahead in the direction d (+-1)."""
    w = c[C_W]
    y = (beta - c[C_BLO]) / w
    i = int(np.floor(y))
    if d < 0 and y == i:
        i -= 1
    n = int(c[C_NPAN])
    i = min(max(i, 0), n - 1)
    return i, 2.0 * (y - i) - 1.0


@_helper
def _coefs(i, st, tab, c):
    """Fill the rows K_Q .. K_W3 of panel i of the working table for the level st (unless they hold it):
    the Chebyshev coefficients of P^T Q P, its derivative [1/rad], P^T S P, its derivative, omega2 and
    omega3 on that panel (the combinations of the tabled functions with the level's coefficients)."""
    key = tab[i, K_KEY]
    if key[0] == st[ST_C0] and key[1] == st[ST_P1] and key[2] == st[ST_P2]:
        return
    p1 = st[ST_P1]
    p2 = st[ST_P2]
    q0 = p1 * p1
    q1 = 2.0 * p1 * p2
    q2 = p2 * p2
    row = tab[i]
    for n in range(N_COEF):
        row[K_Q, n] = q0 * row[Q11, n] + q1 * row[Q11 + 1, n] + q2 * row[Q11 + 2, n]
        row[K_DQ, n] = q0 * row[T_SLOPES, n] + q1 * row[T_SLOPES + 1, n] + q2 * row[T_SLOPES + 2, n]
        row[K_S, n] = q0 * row[S11, n] + q1 * row[S11 + 1, n] + q2 * row[S11 + 2, n]
        row[K_DS, n] = q0 * row[T_SLOPES + 3, n] + q1 * row[T_SLOPES + 4, n] + q2 * row[T_SLOPES + 5, n]
        row[K_W2, n] = p1 * row[0, n] + p2 * row[1, n]
        row[K_W3, n] = p1 * row[PHI21, n] + p2 * row[PHI22, n]
    key[0] = st[ST_C0]
    key[1] = p1
    key[2] = p2


@_helper
def _level_values(beta, d, st, tab, c):
    """(W, dW/dbeta, F, dF/dbeta): omega1^2 [1/s^2] and F2/m [m/s^2] on the level st at beta (the four
    combined series of the panel summed in one pass of the Chebyshev recurrence)."""
    i, u = _panel(beta, d, c)
    _coefs(i, st, tab, c)
    row = tab[i]
    t0 = 1.0
    t1 = u
    Q = row[K_Q, 0] + row[K_Q, 1] * u
    dQ = row[K_DQ, 0] + row[K_DQ, 1] * u
    S = row[K_S, 0] + row[K_S, 1] * u
    dS = row[K_DS, 0] + row[K_DS, 1] * u
    for n in range(2, N_COEF):
        t2 = 2.0 * u * t1 - t0
        Q += row[K_Q, n] * t2
        dQ += row[K_DQ, n] * t2
        S += row[K_S, n] * t2
        dS += row[K_DS, n] * t2
        t0 = t1
        t1 = t2
    s = np.sin(beta)
    co = np.cos(beta)
    W = st[ST_C0] - c[C_A] * s - Q
    dW = -c[C_A] * co - dQ
    F = c[C_R2R] * S - c[C_R2RHO] * W + c[C_G] * s
    dF = c[C_R2R] * dS - c[C_R2RHO] * dW + c[C_G] * co
    return W, dW, F, dF


@_helper
def _curvatures(i, st, curv, c):
    """Bounds of |W''| [1/(s^2 rad^2)] and |(F2/m)''| on panel i for the level st."""
    p1 = st[ST_P1]
    p2 = st[ST_P2]
    q0 = p1 * p1
    q1 = 2.0 * abs(p1 * p2)
    q2 = p2 * p2
    mw = c[C_A] + q0 * curv[i, 0] + q1 * curv[i, 1] + q2 * curv[i, 2]
    mf = c[C_R2R] * (q0 * curv[i, 3] + q1 * curv[i, 4] + q2 * curv[i, 5]) + c[C_R2RHO] * mw + c[C_G]
    return mw * (1.0 + 1e-12), mf * (1.0 + 1e-12)


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
def _root(beta_a, d, h, which, st, tab, c):
    """Zero of W (which = 0) or F (1) in s in [0, h] from beta_a in direction d, where the value is
    > 0 at s = 0 and <= 0 at s = h: safeguarded Newton-bisection. Returns (beta, evaluations)."""
    lo = 0.0
    hi = h
    s = 0.5 * h
    n = 0
    for _ in range(MAX_NEWTON):
        W, dW, F, dF = _level_values(beta_a + d * s, d, st, tab, c)
        n += 1
        f = W if which == 0.0 else F
        g = d * (dW if which == 0.0 else dF)
        if f > 0.0:
            lo = s
        else:
            hi = s
        if hi - lo <= 2e-16 * (abs(beta_a) + hi):
            break
        step = -f / g if g != 0.0 else 0.0
        s_new = s + step
        if not (lo < s_new < hi) or g == 0.0:
            s_new = 0.5 * (lo + hi)
        b = beta_a + d * s
        if beta_a + d * s_new == b:  # Newton stalls within one float of beta: the adjacent float, on the zero's side
            s_new = d * (np.nextafter(b, b + d if f > 0.0 else b - d) - beta_a)
            if not (lo < s_new < hi):
                break
        s = s_new
    return beta_a + d * hi, n


@_helper
def _march(beta0, d, st, tab, curv, c, w_start_zero):
    """First event moving from beta0 in the direction d (+-1): (kind EV_*, beta_event, f2_min [m/s^2]
    along the way (F2/m), evaluations). ``w_start_zero``: beta0 is a turning point (W = 0 there)."""
    w = c[C_W]
    lo_edge = c[C_BLO]
    hi_edge = c[C_BLO] + c[C_NPAN] * w
    Wa, dWa, Fa, dFa = _level_values(beta0, d, st, tab, c)
    if w_start_zero > 0.0:
        Wa = 0.0
    ga_w = d * dWa
    ga_f = d * dFa
    fmin = Fa
    beta_a = beta0
    h = 0.25 * w
    n = 1
    for _ in range(MAX_MARCH):
        i, u = _panel(beta_a, d, c)
        edge = c[C_BLO] + (i + 1) * w if d > 0 else c[C_BLO] + i * w
        room = d * (edge - beta_a)
        if room <= 1e-15 * w:  # on an edge: the next panel
            i += 1 if d > 0 else -1
            edge = c[C_BLO] + (i + 1) * w if d > 0 else c[C_BLO] + i * w
            room = d * (edge - beta_a)
        if room <= 0.0 or beta_a <= lo_edge or beta_a >= hi_edge:
            return EV_FAIL, beta_a, fmin, n
        hh = min(h, room)
        beta_b = beta_a + d * hh
        if d * (edge - beta_b) < 1e-15:
            beta_b = edge
            hh = room
        Wb, dWb, Fb, dFb = _level_values(beta_b, d, st, tab, c)
        n += 1
        gb_w = d * dWb
        gb_f = d * dFb
        mw, mf = _curvatures(i, st, curv, c)
        kw = _classify(Wa, ga_w, Wb, gb_w, mw, hh)
        kf = _classify(Fa, ga_f, Fb, gb_f, mf, hh)
        if kw == 0 and kf == 0:
            beta_a, Wa, ga_w, Fa, ga_f = beta_b, Wb, gb_w, Fb, gb_f
            fmin = min(fmin, Fb)
            h = min(2.0 * hh, w)
            continue
        if kw != 2 and kf != 2 or hh <= H_MIN:
            bw = np.inf
            bf = np.inf
            if kw == 1 or (kw == 2 and Wb <= 0.0 < Wa):
                rw, m = _root(beta_a, d, hh, 0.0, st, tab, c)
                n += m
                bw = d * (rw - beta0)
            if kf == 1 or (kf == 2 and Fb <= 0.0 < Fa):
                rf, m = _root(beta_a, d, hh, 1.0, st, tab, c)
                n += m
                bf = d * (rf - beta0)
            if bw == np.inf and bf == np.inf:
                if Fa <= 0.0:  # F2 = 0 at the start, falling
                    return EV_FALL, beta_a, min(fmin, Fa), n
                if Wa <= 0.0 and w_start_zero == 0.0:
                    return EV_TURN, beta_a, fmin, n
                # a touch below the resolution: passed
                beta_a, Wa, ga_w, Fa, ga_f = beta_b, Wb, gb_w, Fb, gb_f
                fmin = min(fmin, Fb)
                h = min(2.0 * hh, w)
                continue
            if bf <= bw:
                return EV_FALL, beta0 + d * bf, min(fmin, 0.0), n
            return EV_TURN, beta0 + d * bw, fmin, n
        h = 0.5 * hh
    return EV_CAP, beta_a, fmin, n


@_helper
def _dclenshaw(row, u0, du):
    """sum_n row[n] (T_n(u0 + du) - T_n(u0)), accurate relative to itself for small du (the
    forward recurrence of the differences D_n = T_n(u0 + du) - T_n(u0))."""
    u = u0 + du
    t_prev = 1.0
    t_cur = u0
    d_prev = 0.0
    d_cur = du
    acc = row[1] * du
    for n in range(1, N_COEF - 1):
        d_next = 2.0 * u * d_cur + 2.0 * du * t_cur - d_prev
        t_next = 2.0 * u0 * t_cur - t_prev
        acc += row[n + 1] * d_next
        d_prev = d_cur
        d_cur = d_next
        t_prev = t_cur
        t_cur = t_next
    return acc


@_helper
def _w_change(beta_ref, delta, st, tab, c):
    """omega1^2(beta_ref + delta) - omega1^2(beta_ref) [1/s^2] on the level st, without the cancellation
    of the two values (the Chebyshev differences of the panel of beta_ref; directly if delta reaches
    far outside it)."""
    i, u0 = _panel(beta_ref, 1.0 if delta > 0.0 else -1.0, c)
    du = 2.0 * delta / c[C_W]
    ds = 2.0 * np.cos(beta_ref + 0.5 * delta) * np.sin(0.5 * delta)
    _coefs(i, st, tab, c)
    if abs(u0 + du) > 1.25:
        j, u = _panel(beta_ref + delta, 1.0, c)
        _coefs(j, st, tab, c)
        dq = _clenshaw(tab[j, K_Q], u) - _clenshaw(tab[i, K_Q], u0)
    else:
        dq = _dclenshaw(tab[i, K_Q], u0, du)
    return -c[C_A] * ds - dq


@_helper
def _densities(beta, w_shifted, st, tab, c):
    """(dt/|dbeta| [s/rad], dalpha/|dbeta|) at beta where omega1^2 = w_shifted [1/s^2]."""
    if not w_shifted > 0.0:
        return 0.0, 0.0
    i, u = _panel(beta, 1.0, c)
    _coefs(i, st, tab, c)
    w3 = _clenshaw(tab[i, K_W3], u)
    inv = 1.0 / np.sqrt(w_shifted)
    return c[C_TIME] * inv, -c[C_ALPHA] * w3 / (1.0 - c[C_X] * np.cos(beta)) * inv


@_helper
def _mapped(theta, beta_s, beta_e, mode):
    """The substitution of ``_leg``: (ref, delta, |dbeta/dtheta|) with beta = ref + delta, ref the
    singular end nearest (mode 0: none, ref = beta_s; 1: singular at the start; 2: at the end; 3: both)."""
    L = beta_e - beta_s
    if mode == 0:
        return beta_s, L * theta, abs(L)
    sh = np.sin(0.5 * theta)
    if mode == 1:
        return beta_s, 2.0 * L * sh * sh, abs(L) * np.sin(theta)
    if mode == 2:
        return beta_e, -2.0 * L * sh * sh, abs(L) * np.sin(theta)
    if theta <= 0.5 * np.pi:
        return beta_s, L * sh * sh, 0.5 * abs(L) * np.sin(theta)
    ch = np.cos(0.5 * theta)
    return beta_e, -L * ch * ch, 0.5 * abs(L) * np.sin(theta)


@_helper
def _gl(a, b, beta_s, beta_e, mode, ws, we, st, tab, c, xg, wg):
    """Gauss-Legendre over theta in [a, b] of the time and alpha densities: (t [s], alpha [rad]).
    ws, we: omega1^2 as computed at the ends (subtracted where the end is singular, linearly between)."""
    t = 0.0
    al = 0.0
    half = 0.5 * (b - a)
    mid = 0.5 * (a + b)
    L = beta_e - beta_s
    slope = (we - ws) / L if mode == 3 else 0.0
    for q in range(xg.shape[0]):
        th = mid + half * xg[q]
        ref, delta, jac = _mapped(th, beta_s, beta_e, mode)
        dw = _w_change(ref, delta, st, tab, c)
        if mode == 0:
            w = ws + dw
        elif mode == 3:
            w = dw - slope * delta
        else:
            w = dw
        dt, da = _densities(ref + delta, w, st, tab, c)
        t += wg[q] * dt * jac
        al += wg[q] * da * jac
    return t * half, al * half


@_helper
def _leg(beta_s, beta_e, sing_s, sing_e, st, tab, c, xg, wg, stack):
    """Time [s] and alpha [rad] from beta_s to beta_e (monotone motion), W vanishing at the ends
    flagged singular. Returns (t, alpha, ok, evaluations)."""
    if beta_e == beta_s:
        return 0.0, 0.0, True, 0
    mode = (1 if sing_s > 0.0 else 0) + (2 if sing_e > 0.0 else 0)
    ws = 0.0
    we = 0.0
    if sing_s > 0.0 or mode == 0:
        ws = _level_values(beta_s, 1.0, st, tab, c)[0]
    if sing_e > 0.0:
        we = _level_values(beta_e, 1.0, st, tab, c)[0]
    top = np.pi if mode == 3 else (0.5 * np.pi if mode != 0 else 1.0)
    n_st = 0
    stack[0, 0] = 0.0
    stack[0, 1] = top
    t0, a0 = _gl(0.0, top, beta_s, beta_e, mode, ws, we, st, tab, c, xg, wg)
    stack[0, 2] = t0
    stack[0, 3] = a0
    tol = QUAD_RTOL * abs(t0) + 1e-300
    n_st = 1
    t_sum = 0.0
    a_sum = 0.0
    n_ev = xg.shape[0]
    for _ in range(MAX_PANELS):
        if n_st == 0:
            return t_sum, a_sum, True, n_ev
        n_st -= 1
        a = stack[n_st, 0]
        b = stack[n_st, 1]
        whole = stack[n_st, 2]
        m = 0.5 * (a + b)
        tl, al = _gl(a, m, beta_s, beta_e, mode, ws, we, st, tab, c, xg, wg)
        tr, ar = _gl(m, b, beta_s, beta_e, mode, ws, we, st, tab, c, xg, wg)
        n_ev += 2 * xg.shape[0]
        if abs(tl + tr - whole) <= tol or b - a < 1e-14 * top:
            t_sum += tl + tr
            a_sum += al + ar
            continue
        if n_st + 2 > stack.shape[0]:
            return t_sum, a_sum, False, n_ev
        stack[n_st, 0] = m
        stack[n_st, 1] = b
        stack[n_st, 2] = tr
        stack[n_st, 3] = ar
        stack[n_st + 1, 0] = a
        stack[n_st + 1, 1] = m
        stack[n_st + 1, 2] = tl
        stack[n_st + 1, 3] = al
        n_st += 2
    return t_sum, a_sum, False, n_ev


@_helper
def _at_time(beta_s, beta_e, sing_s, sing_e, target, st, tab, c, xg, wg, stack):
    """beta where the time from beta_s (towards beta_e, monotone) reaches target [s] < the leg's time,
    and alpha [rad] up to it: Newton on t(beta) (dt/dbeta = (rho/r)/sqrt(W)) safeguarded by bisection.
    Returns (beta, alpha, ok, evaluations)."""
    d = 1.0 if beta_e > beta_s else -1.0
    lo = 0.0
    hi = abs(beta_e - beta_s)
    s = 0.5 * hi
    n = 0
    alpha = 0.0
    ok = True
    for _ in range(MAX_NEWTON):
        t, alpha, good, m = _leg(beta_s, beta_s + d * s, sing_s, 0.0, st, tab, c, xg, wg, stack)
        n += m
        ok = ok and good
        err = t - target
        if err > 0.0:
            hi = s
        else:
            lo = s
        if abs(err) <= 1e-14 * target + 1e-16 or hi - lo <= 4e-16 * (abs(beta_s) + hi):
            return beta_s + d * s, alpha, ok, n
        W = _level_values(beta_s + d * s, d, st, tab, c)[0]
        n += 1
        s_new = s - err * np.sqrt(max(W, 0.0)) / c[C_TIME]
        if not (lo < s_new < hi):
            s_new = 0.5 * (lo + hi)
        s = s_new
    return beta_s + d * s, alpha, False, n


@_helper
def _transversal(beta, st, tab, c, p):
    """Whether omega1 = 0 at beta on the level st is a transversal zero at the simulation's rtol
    (``rules.transversal_omega1_zero``)."""
    i, u = _panel(beta, 1.0, c)
    _coefs(i, st, tab, c)
    w2 = _clenshaw(tab[i, K_W2], u)
    w3 = _clenshaw(tab[i, K_W3], u)
    return rules.transversal_omega1_zero(beta, 0.0, w2, w3, p, c[C_RTOL])


@_helper
def _extend(res, beta):
    """Widen the traversed range [res[R_LO], res[R_HI]] [rad] to hold beta."""
    res[R_LO] = min(res[R_LO], beta)
    res[R_HI] = max(res[R_HI], beta)


@_helper
def _f_min(lo, hi, st, tab, c):
    """Smallest F2/m [m/s^2] on [lo, hi] [rad]: samples every 1/4 panel, then the zero of dF/dbeta
    bracketed around the smallest interior sample (bisection to 1e-6 of a panel)."""
    n = min(int(np.ceil((hi - lo) / (0.25 * c[C_W]))), 4000) + 1
    best = np.inf
    k_best = 0
    step = (hi - lo) / max(n - 1, 1)
    for k in range(n):
        F = _level_values(lo + k * step, 1.0, st, tab, c)[2]
        if F < best:
            best = F
            k_best = k
    if k_best == 0 or k_best == n - 1:
        return best
    a = lo + (k_best - 1) * step
    b = lo + (k_best + 1) * step
    if not (_level_values(a, 1.0, st, tab, c)[3] < 0.0 < _level_values(b, 1.0, st, tab, c)[3]):
        return best
    for _ in range(MAX_NEWTON):
        m = 0.5 * (a + b)
        if b - a < 1e-6 * c[C_W]:  # F there is within |F''| 1e-14 of its minimum
            break
        if _level_values(m, 1.0, st, tab, c)[3] < 0.0:
            a = m
        else:
            b = m
    return min(best, _level_values(0.5 * (a + b), 1.0, st, tab, c)[2])


@_helper
def _finish(res, resi, beta, w1, st, tab, c, t, alpha):
    """Write the end state (beta, omega1, z(beta)), t_end and the revolutions into the result rows."""
    i, u = _panel(beta, 1.0, c)
    _extend(res, beta)
    res[R_T] = t
    res[R_REV] = alpha / (2.0 * np.pi)
    res[R_BETA] = beta
    res[R_W1] = w1
    _coefs(i, st, tab, c)
    res[R_W2] = _clenshaw(tab[i, K_W2], u)
    res[R_W3] = _clenshaw(tab[i, K_W3], u)


@_helper
def _end_on_rim(res, resi, bt, d, ok, st, tab, c, t_max, alpha):
    """Ends the state on the rim at t_max at beta = bt, moving in direction d (status max_steps unless ok)."""
    if not ok:
        resi[RI_STATUS] = MAX_STEPS
    W = _level_values(bt, d, st, tab, c)[0]
    _finish(res, resi, bt, d * np.sqrt(max(W, 0.0)), st, tab, c, t_max, alpha)
    resi[RI_OUTCOME] = ON_RIM_AT_T_MAX


@_helper
def _end_periodic(res, resi, b, st, tab, c, t, alpha, half):
    """Ends the state as periodic rolling at its second counted turning point b, time t [s], half period [s]."""
    _finish(res, resi, b, 0.0, st, tab, c, t, alpha)
    res[R_HALF] = half
    resi[RI_OUTCOME] = PERIODIC_ROLLING


@_helper
def _end_fall(res, resi, b, d, st, tab, c, t, alpha):
    """Ends the state where the ball leaves the rim (F2 = 0) at beta = b, moving in direction d, time t [s]."""
    W = _level_values(b, d, st, tab, c)[0]
    _finish(res, resi, b, d * np.sqrt(max(W, 0.0)), st, tab, c, t, alpha)
    resi[RI_FELL] = 1


@_helper
def _count_turn(count, t_first, t):
    """One more counted turning point at time t [s]: (count, time of the first counted one [s])."""
    count += 1
    return count, (t if count == 1 else t_first)


@_helper
def _end_failed(res, resi, k, fmin, beta0, w10, st, tab, c):
    """Ends the state at its start when the march failed (k: EV_FAIL non-finite, else the step cap)."""
    resi[RI_STATUS] = NON_FINITE if k == EV_FAIL else MAX_STEPS
    resi[RI_OUTCOME] = ON_RIM_AT_T_MAX
    res[R_F2MIN] = fmin
    _finish(res, resi, beta0, w10, st, tab, c, 0.0, 0.0)


@_helper
def solve_one(x, st, tab, curv, c, p, xg, wg, stack, res, resi):
    """One conservative rolling state that neither starts off the rim nor on a steady motion.

    x: the state (beta [rad], omega1 [1/s], ...) at the start, its level st (C0, P1, P2). Writes res (N_R floats:
    t_end [s], f2_min [N/kg], half_period [s], revolutions, end state) and resi (outcome, status,
    evaluations, fell: 1 when the ball left the rim at the end state)."""
    resi[RI_EVALS] = _solve_legs(x, st, tab, curv, c, p, xg, wg, stack, res, resi)


@_helper
def _solve_legs(x, st, tab, curv, c, p, xg, wg, stack, res, resi):
    """``solve_one``'s work; returns the number of evaluations of the tables."""
    beta0, w10 = x[0], x[1]
    t_max = c[C_TMAX]
    resi[RI_STATUS] = OK
    resi[RI_FELL] = 0
    res[R_HALF] = np.nan
    res[R_LO] = res[R_HI] = beta0
    start_turn = w10 == 0.0
    if start_turn:
        d = 1.0 if _level_values(beta0, 1.0, st, tab, c)[1] > 0.0 else -1.0
    else:
        d = 1.0 if w10 > 0.0 else -1.0
    n_ev = 0
    # leg 1: from beta0 in direction d
    ts = 1.0 if start_turn else 0.0
    k1, b1, fmin1, m = _march(beta0, d, st, tab, curv, c, ts)
    s1 = 1.0 if k1 == EV_TURN else 0.0
    n_ev += m
    fmin = fmin1
    if k1 == EV_FAIL or k1 == EV_CAP:
        _end_failed(res, resi, k1, fmin, beta0, w10, st, tab, c)
        return n_ev
    t1, a1, ok1, m = _leg(beta0, b1, ts, s1, st, tab, c, xg, wg, stack)
    n_ev += m
    if not ok1:
        resi[RI_STATUS] = MAX_STEPS
    if t1 > t_max:  # on the rim at t_max, during leg 1
        bt, at, ok, m = _at_time(beta0, b1, ts, s1, t_max, st, tab, c, xg, wg, stack)
        n_ev += m
        _end_on_rim(res, resi, bt, d, ok, st, tab, c, t_max, at)
        res[R_F2MIN] = fmin
        return n_ev
    _extend(res, b1)
    if k1 == EV_FALL:
        _end_fall(res, resi, b1, d, st, tab, c, t1, a1)
        res[R_F2MIN] = fmin
        return n_ev
    # the other way: from beta0 in direction -d (unless beta0 itself is the turning point)
    if start_turn:
        k2, b2, t2, a2 = EV_TURN, beta0, 0.0, 0.0
        cross_first = _transversal(beta0, st, tab, c, p)
    else:
        k2, b2, fmin2, m = _march(beta0, -d, st, tab, curv, c, 0.0)
        n_ev += m
        fmin = min(fmin, fmin2)
        if k2 == EV_FAIL or k2 == EV_CAP:
            _end_failed(res, resi, k2, fmin, beta0, w10, st, tab, c)
            return n_ev
        t2, a2, ok2, m = _leg(beta0, b2, 0.0, 1.0 if k2 == EV_TURN else 0.0, st, tab, c, xg, wg, stack)
        n_ev += m
        if not ok2:
            resi[RI_STATUS] = MAX_STEPS
        cross_first = False
    res[R_F2MIN] = fmin
    # pieces of the motion after leg 1: b1 -> beta0 (t1), beta0 -> b2 (t2), then (if b2 is a turning
    # point) b2 -> beta0 (t2), beta0 -> b1 (t1), ... Turning points b1 (turn_b1) and b2 (turn_b2).
    turn_b1 = _transversal(b1, st, tab, c, p)
    turn_b2 = k2 == EV_TURN and _transversal(b2, st, tab, c, p)
    count = 1 if cross_first else 0
    t_first = 0.0
    if turn_b1:
        count, t_first = _count_turn(count, t_first, t1)
        if count == 2:  # the start was the first zero
            _end_periodic(res, resi, b1, st, tab, c, t1, a1, t1 - t_first)
            return n_ev
    t, alpha = t1, a1
    at_b1 = True  # the ball is at the turning point b1 (else at b2)
    for _ in range(MAX_LEGS):
        if at_b1:
            # b1 -> beta0 -> b2
            if t + t1 + t2 > t_max:
                if t + t1 > t_max:
                    bt, at, ok, m = _at_time(b1, beta0, 1.0, ts, t_max - t, st, tab, c, xg, wg, stack)
                    alpha_t = alpha + at
                else:
                    bt, at, ok, m = _at_time(beta0, b2, ts, 1.0 if k2 == EV_TURN else 0.0, t_max - t - t1, st, tab,
                                             c, xg, wg, stack)
                    alpha_t = alpha + a1 + at
                n_ev += m
                _end_on_rim(res, resi, bt, -d, ok, st, tab, c, t_max, alpha_t)
                return n_ev
            t += t1 + t2
            alpha += a1 + a2
            _extend(res, b2)
            if k2 == EV_FALL:
                _end_fall(res, resi, b2, -d, st, tab, c, t, alpha)
                return n_ev
            at_b1 = False
            if turn_b2:
                count, t_first = _count_turn(count, t_first, t)
                if count == 2:
                    _end_periodic(res, resi, b2, st, tab, c, t, alpha, t - t_first)
                    return n_ev
        else:
            # b2 -> beta0 -> b1
            if t + t1 + t2 > t_max:
                if t + t2 > t_max:
                    bt, at, ok, m = _at_time(b2, beta0, 1.0, ts, t_max - t, st, tab, c, xg, wg, stack)
                    alpha_t = alpha + at
                else:
                    bt, at, ok, m = _at_time(beta0, b1, ts, 1.0, t_max - t - t2, st, tab, c, xg, wg,
                                             stack)
                    alpha_t = alpha + a2 + at
                n_ev += m
                _end_on_rim(res, resi, bt, d, ok, st, tab, c, t_max, alpha_t)
                return n_ev
            t += t1 + t2
            alpha += a1 + a2
            at_b1 = True
            if turn_b1:
                count, t_first = _count_turn(count, t_first, t)
                if count == 2:
                    _end_periodic(res, resi, b1, st, tab, c, t, alpha, t - t_first)
                    return n_ev
    # turning points that do not count, more than MAX_LEGS of them before t_max
    resi[RI_STATUS] = MAX_STEPS
    resi[RI_OUTCOME] = ON_RIM_AT_T_MAX
    _finish(res, resi, b1 if at_b1 else b2, 0.0, st, tab, c, t, alpha)
    return n_ev


def working_table(table):
    """A working copy (n_panels, N_ROWS, N_COEF) of a ``reduced_tables.Table`` for one thread: its values, the
    slopes of its forms, and room for the combined series of one level per panel (keys NaN: empty)."""
    out = np.full((table.values.shape[0], N_ROWS, N_COEF), np.nan)
    out[:, :T_SLOPES] = table.values
    out[:, T_SLOPES:T_SLOPES + N_FORMS] = table.slopes
    return out


@kernel(runtime=True)
def solve_many(x0, levels, tab, curv, c, p, xg, wg, res, resi):
    """``solve_one`` for each row of x0 (m, 4) with its level row (C0, P1, P2): results into res (m, N_R)
    and resi (m, N_RI); tab: a ``working_table`` (written: one per thread). Falls are
    classified by ``rules.fall_outcome`` here."""
    stack = np.empty((MAX_PANELS + 4, 4))
    for n in range(x0.shape[0]):
        solve_one(x0[n], levels[n], tab, curv, c, p, xg, wg, stack, res[n], resi[n])
        fmin = _f_min(res[n, R_LO], res[n, R_HI], levels[n], tab, c)
        res[n, R_F2MIN] = min(fmin, 0.0) if resi[n, RI_FELL] == 1 else fmin
        if resi[n, RI_FELL] == 1:
            resi[n, RI_OUTCOME] = rules.fall_outcome(res[n, R_BETA], res[n, R_W1], res[n, R_W3], 0.0, 0.0, p)
