/* Exact rolling legs, compiled ahead of time (when rimroll is installed).

   The same algorithm as solver/engine/reduced_rolling.py (read its docstring first: legs, panels,
   bounds, root isolation, quadrature, turning points), written in C so that the exact solver needs
   no compile at run time. reduced_legs.py calls rimroll_exact_legs through ctypes (which releases
   the GIL, so threads run chunks of jobs in parallel) after checking rimroll_exact_layout against
   the Python constants; without this library (no C compiler at install) it uses the numba kernel
   reduced_rolling.legs. tests/solver/engine/test_exact_legs_c.py compares the two on the Fig. 11
   section's legs.

   Arrays (C order, float64): jobs (m, N_J), out (m, N_O), tab (n_panels, N_FUNCTIONS, N_COEF),
   nod (n_panels, N_NODE_ROWS, N_NODES), spread (n_panels, N_SPREAD), c (N_C), rule (N_RULE, N_NODES).
   Units as in reduced_rolling.py: beta [rad], W = omega1^2 [1/s^2], F = F2/m [m/s^2], t [s].

   Differences from the numba kernel, none in what is computed: a piece with no turning point at its
   ends (modes 0, 4, 5) evaluates its series at the nodes by one forward recurrence of T_n (the numba
   kernel forms T_n(u0 + du) as T_n(u0) plus a difference, twice the work); the Gauss-Kronrod nodes of a
   piece are evaluated together (loops the compiler vectorises); F at a whole panel's nodes is skipped
   where the panel's lower bound of F shows it cannot lower the smallest F seen. Values agree to
   rounding. rimroll_exact_evaluate is reduced_tables.evaluate_many. */

#define PY_SSIZE_T_CLEAN
#include <Python.h>
#include <math.h>

#ifndef M_PI
#define M_PI 3.14159265358979323846
#endif

#define N_COEF 16
#define N_NODES 15
#define N_FUNCTIONS 13
#define N_NODE_ROWS 9
#define N_SPREAD 7
#define N_J 10
#define N_O 8
#define N_C 9
#define N_RULE 8
#define N_WORK 6
#define MAX_STACK 400
#define MAX_MARCH 4000
#define MAX_QUAD 4000
#define MAX_NEWTON 100
#define H_MIN 1e-13
#define QUAD_RTOL 1e-10
#define NEAR 1.0

/* table functions (reduced_tables) */
enum { Q11 = 4, Q12 = 5, Q22 = 6, S11 = 7, S12 = 8, S22 = 9, SIN = 10, G21 = 11, G22 = 12 };
/* node rows (reduced_tables.NODE_FUNCTIONS order) */
enum { N_SIN, N_Q11, N_Q12, N_Q22, N_S11, N_S12, N_S22, N_G21, N_G22 };
/* constants c */
enum { C_A, C_R2RHO, C_R2R, C_G, C_TIME, C_ALPHA, C_BLO, C_W, C_NPAN };
/* job row */
enum { J_BETA, J_DIR, J_SING, J_STOP, J_C0, J_Q0, J_Q1, J_Q2, J_P1, J_P2 };
/* output row */
enum { O_KIND, O_BETA, O_T, O_ALPHA, O_FMIN, O_EVALS, O_OK, O_BMIN };
/* event kinds */
enum { EV_TURN, EV_FALL, EV_STOP, EV_FAIL, EV_CAP, EV_NONE };
/* rule rows */
enum { R_NODES = 0, R_KRONROD = 1, R_GAUSS = 2, R_SIN_QUARTER = 3, R_SIN_HALF = 5 };

/* The level's combined series on one panel (reduced_rolling's work array). */
typedef struct {
    double wc[N_COEF], wd[N_COEF], fc[N_COEF], fd[N_COEF], gc[N_COEF];
    long panel;
    int have_fd; /* fd is computed only when a value of dF/dbeta is needed (the march, a root of F, F's minimum) */
    int have_gc; /* gc only when a quadrature on the series needs it */
    double mw, mf, lw, lf;
} Work;

typedef struct {
    const double *job, *tab, *nod, *spread, *c, *rule;
    double *out;
    Work work;
    double stack[MAX_STACK][2];
} Leg;

typedef struct { double w, dw, f, df; } Values;

#define TAB(L, i, fn, n) ((L)->tab[((size_t)(i) * N_FUNCTIONS + (fn)) * N_COEF + (n)])
#define NOD(L, i, r, m) ((L)->nod[((size_t)(i) * N_NODE_ROWS + (r)) * N_NODES + (m)])
#define RULE(L, r, m) ((L)->rule[(r) * N_NODES + (m)])

static long n_panels(const Leg *L) { return (long)L->c[C_NPAN]; }

/* Index of the panel holding beta (on an edge: the panel ahead in the direction d), or -1 outside. */
static long panel_of(double beta, double d, const double *c) {
    double y = (beta - c[C_BLO]) / c[C_W];
    double fl = floor(y);
    if (!isfinite(fl)) return -1;
    long i = (long)fl;
    if (d < 0 && y == fl) i -= 1;
    if (i < 0 || i >= (long)c[C_NPAN]) return -1;
    return i;
}

static double local_u(double beta, long i, const double *c) { return 2.0 * ((beta - c[C_BLO]) / c[C_W] - i) - 1.0; }

static void see_f(double f, double beta, double *out) {
    if (f < out[O_FMIN]) {
        out[O_FMIN] = f;
        out[O_BMIN] = beta;
    }
}

static void derivative(const double *src, double *dst) {
    double b2 = 0.0, b1 = 0.0;
    for (int k = N_COEF - 2; k >= 0; k--) {
        double dk = b2 + 2.0 * (k + 1) * src[k + 1];
        dst[k] = dk;
        b2 = b1;
        b1 = dk;
    }
    dst[N_COEF - 1] = 0.0;
    dst[0] *= 0.5;
}

/* n^2 (n^2 - 1) / 3: Markov's bound of |T_n''| on [-1, 1]. */
static const double MARKOV[N_COEF] = {0, 0, 4, 24, 80, 200, 420, 784, 1344, 2160, 3300, 4840, 6864, 9464, 12740, 16800};

/* The level's series of W and F on panel i, W's d/du and the bounds (G and F's d/du when needed: need_gc, need_fd). */
static void combine(Leg *L, long i) {
    Work *w = &L->work;
    if (w->panel == i) return;
    const double *job = L->job, *c = L->c;
    double q0 = job[J_Q0], q1 = job[J_Q1], q2 = job[J_Q2];
    const double *sn = &TAB(L, i, SIN, 0), *t11 = &TAB(L, i, Q11, 0), *t12 = &TAB(L, i, Q12, 0), *t22 = &TAB(L, i, Q22, 0),
                 *s11 = &TAB(L, i, S11, 0), *s12 = &TAB(L, i, S12, 0), *s22 = &TAB(L, i, S22, 0);
    for (int n = 0; n < N_COEF; n++) {
        double wn = -c[C_A] * sn[n] - (q0 * t11[n] + q1 * t12[n] + q2 * t22[n]);
        w->wc[n] = wn;
        w->fc[n] = c[C_R2R] * (q0 * s11[n] + q1 * s12[n] + q2 * s22[n]) - c[C_R2RHO] * wn + c[C_G] * sn[n];
    }
    w->wc[0] += job[J_C0]; /* the level's constant, in c_0 only */
    w->fc[0] = c[C_R2R] * (q0 * s11[0] + q1 * s12[0] + q2 * s22[0]) - c[C_R2RHO] * w->wc[0] + c[C_G] * sn[0];
    double mw = 0.0, mf = 0.0, lw = 0.0, lf = 0.0;
    for (int n = 1; n < N_COEF; n++) {
        mw += fabs(w->wc[n]) * MARKOV[n];
        mf += fabs(w->fc[n]) * MARKOV[n];
        lw += fabs(w->wc[n]);
        lf += fabs(w->fc[n]);
    }
    derivative(w->wc, w->wd);
    w->have_fd = 0;
    w->have_gc = 0;
    w->panel = i;
    w->mw = mw * (1.0 + 1e-12);
    w->mf = mf * (1.0 + 1e-12);
    w->lw = w->wc[0] - lw * (1.0 + 1e-12);
    w->lf = w->fc[0] - lf * (1.0 + 1e-12);
}

/* The combined panel's series of G = omega3 / (1 - x cos beta), computed once a quadrature needs it. */
static void need_gc(Leg *L) {
    Work *w = &L->work;
    if (!w->have_gc) {
        const double *g21 = &TAB(L, w->panel, G21, 0), *g22 = &TAB(L, w->panel, G22, 0);
        for (int n = 0; n < N_COEF; n++) w->gc[n] = L->job[J_P1] * g21[n] + L->job[J_P2] * g22[n];
        w->have_gc = 1;
    }
}

/* The combined panel's series of dF/du, computed once it is needed. */
static void need_fd(Work *w) {
    if (!w->have_fd) {
        derivative(w->fc, w->fd);
        w->have_fd = 1;
    }
}

/* Value at u of one combined series cs. */
static double value_at(const double *cs, double u) {
    double t0 = 1.0, t1 = u, v = cs[0] + cs[1] * u;
    for (int n = 2; n < N_COEF; n++) {
        double t2 = 2.0 * u * t1 - t0;
        v += cs[n] * t2;
        t0 = t1;
        t1 = t2;
    }
    return v;
}

/* (W, dW/dbeta, F, dF/dbeta) at u of the combined panel (scale = 2/width); needs fd (need_fd). */
static Values values_at(const Work *w, double u, double scale) {
    double t0 = 1.0, t1 = u;
    double W = w->wc[0] + w->wc[1] * u, dW = w->wd[0] + w->wd[1] * u;
    double F = w->fc[0] + w->fc[1] * u, dF = w->fd[0] + w->fd[1] * u;
    for (int n = 2; n < N_COEF; n++) {
        double t2 = 2.0 * u * t1 - t0;
        W += w->wc[n] * t2;
        dW += w->wd[n] * t2;
        F += w->fc[n] * t2;
        dF += w->fd[n] * t2;
        t0 = t1;
        t1 = t2;
    }
    Values v = {W, dW * scale, F, dF * scale};
    return v;
}

/* (value, d/dbeta) at u of one combined series c and its derivative series dc (scale = 2/width). */
static void series_at(const double *cs, const double *dcs, double u, double scale, double *v_out, double *d_out) {
    double t0 = 1.0, t1 = u;
    double v = cs[0] + cs[1] * u, dv = dcs[0] + dcs[1] * u;
    for (int n = 2; n < N_COEF; n++) {
        double t2 = 2.0 * u * t1 - t0;
        v += cs[n] * t2;
        dv += dcs[n] * t2;
        t0 = t1;
        t1 = t2;
    }
    *v_out = v;
    *d_out = dv * scale;
}

/* 0: f > 0 on the interval; 1: exactly one zero; 2: undecided. */
static int classify(double fa, double ga, double fb, double gb, double m2, double h) {
    double q = m2 * h * h / 8.0;
    if (fa >= 0.0 && fb > 0.0 && fa + 0.5 * ga * h - q > 0.0 && fb - 0.5 * gb * h - q > 0.0) return 0;
    if (fa > 0.0 && fb <= 0.0 && ga + gb + m2 * h < 0.0) return 1;
    return 2;
}

/* Zero of W (which = 0) or F (1) at distance s in [0, h] from beta_a in direction d on panel i. */
static double root(Leg *L, double beta_a, double d, double h, int which, long i, long *n_ev) {
    const double *c = L->c;
    double scale = 2.0 / c[C_W];
    double tol = 4e-16 * (fabs(beta_a) + h + c[C_W]);
    double lo = 0.0, hi = h, s = 0.5 * h;
    for (int it = 0; it < MAX_NEWTON; it++) {
        double f, g;
        if (which == 0) series_at(L->work.wc, L->work.wd, local_u(beta_a + d * s, i, c), scale, &f, &g);
        else series_at(L->work.fc, L->work.fd, local_u(beta_a + d * s, i, c), scale, &f, &g);
        (*n_ev)++;
        g *= d;
        if (f > 0.0) lo = s;
        else hi = s;
        if (hi - lo <= 2.0 * tol) break;
        double s_new = g != 0.0 ? s - f / g : 0.5 * (lo + hi);
        if (fabs(s_new - s) < tol) s_new = f > 0.0 ? s + tol : s - tol;
        if (!(lo < s_new && s_new < hi)) s_new = 0.5 * (lo + hi);
        s = s_new;
    }
    return beta_a + d * hi;
}

/* The first zero of W or F from beta_a towards beta_end (direction d) on panel i. */
static int isolate(Leg *L, double beta_a, double beta_end, double d, long i, int sing, double *b_event, long *n_ev) {
    const double *c = L->c;
    double *out = L->out;
    double scale = 2.0 / c[C_W];
    double mw = L->work.mw * scale * scale, mf = L->work.mf * scale * scale;
    need_fd(&L->work);
    Values a = values_at(&L->work, local_u(beta_a, i, c), scale);
    double Wa = sing ? 0.0 : a.w, Fa = a.f;
    double ga_w = d * a.dw, ga_f = d * a.df;
    double length = d * (beta_end - beta_a);
    double pos = 0.0, h = length;
    (*n_ev)++;
    for (int it = 0; it < MAX_MARCH; it++) {
        if (pos >= length) {
            *b_event = beta_end;
            return EV_NONE;
        }
        double hh = fmin(h, length - pos);
        double beta_b = pos + hh < length ? beta_a + d * hh : beta_end;
        hh = d * (beta_b - beta_a);
        Values b = values_at(&L->work, local_u(beta_b, i, c), scale);
        (*n_ev)++;
        double gb_w = d * b.dw, gb_f = d * b.df;
        int kw = classify(Wa, ga_w, b.w, gb_w, mw, hh);
        int kf = classify(Fa, ga_f, b.f, gb_f, mf, hh);
        int passed = kw == 0 && kf == 0;
        if (!passed && ((kw != 2 && kf != 2) || hh <= H_MIN)) {
            double bw = INFINITY, bf = INFINITY;
            if (kw == 1 || (kw == 2 && b.w <= 0.0 && 0.0 < Wa)) bw = d * (root(L, beta_a, d, hh, 0, i, n_ev) - beta_a);
            if (kf == 1 || (kf == 2 && b.f <= 0.0 && 0.0 < Fa)) bf = d * (root(L, beta_a, d, hh, 1, i, n_ev) - beta_a);
            if (bf < INFINITY && bf <= bw) {
                see_f(0.0, beta_a + d * bf, out);
                *b_event = beta_a + d * bf;
                return EV_FALL;
            }
            if (bw < INFINITY) {
                *b_event = beta_a + d * bw;
                return EV_TURN;
            }
            if (Fa <= 0.0) {
                see_f(Fa, beta_a, out);
                *b_event = beta_a;
                return EV_FALL;
            }
            if (Wa <= 0.0 && !sing) {
                *b_event = beta_a;
                return EV_TURN;
            }
            passed = 1; /* a touch below the resolution */
        }
        if (passed) {
            see_f(b.f, beta_b, out);
            pos += hh;
            beta_a = beta_b;
            Wa = b.w;
            ga_w = gb_w;
            Fa = b.f;
            ga_f = gb_f;
            sing = 0;
            h = 2.0 * hh;
        } else {
            h = 0.5 * hh;
        }
    }
    *b_event = beta_a;
    return EV_CAP;
}

/* Whether W > 0 and F > 0 on the whole panel i by the tabled spreads (no combined series); *f_low: F's lower bound. */
static int clear_panel(const Leg *L, long i, double *f_low) {
    const double *job = L->job, *c = L->c, *sp = L->spread + (size_t)i * N_SPREAD;
    double q0 = job[J_Q0], q1 = job[J_Q1], q2 = job[J_Q2], aq1 = fabs(q1);
    double w0 = job[J_C0] - c[C_A] * TAB(L, i, SIN, 0) - (q0 * TAB(L, i, Q11, 0) + q1 * TAB(L, i, Q12, 0) + q2 * TAB(L, i, Q22, 0));
    double sq = q0 * sp[1] + aq1 * sp[2] + q2 * sp[3];
    *f_low = -INFINITY;
    if (!(w0 - (c[C_A] * sp[0] + sq) > 0.0)) return 0;
    double f0 = c[C_R2R] * (q0 * TAB(L, i, S11, 0) + q1 * TAB(L, i, S12, 0) + q2 * TAB(L, i, S22, 0)) - c[C_R2RHO] * w0
                + c[C_G] * TAB(L, i, SIN, 0);
    double sf = c[C_R2R] * (q0 * sp[4] + aq1 * sp[5] + q2 * sp[6]) + c[C_R2RHO] * sq + (c[C_R2RHO] * c[C_A] + c[C_G]) * sp[0];
    *f_low = f0 - sf;
    return f0 - sf > 0.0;
}

/* Time and alpha across the whole panel i by the tabled Gauss-Kronrod rule; returns ok. f_low: a lower bound of F on
   the panel [m/s^2] (-inf: none); F at the nodes is computed only when it could lower out[O_FMIN]. */
static int full_panel(Leg *L, long i, double f_low, double *tp, double *ap) {
    const double *job = L->job, *c = L->c;
    double *out = L->out;
    double q0 = job[J_Q0], q1 = job[J_Q1], q2 = job[J_Q2], c0 = job[J_C0], ca = c[C_A];
    const double *sn = &NOD(L, i, N_SIN, 0), *n11 = &NOD(L, i, N_Q11, 0), *n12 = &NOD(L, i, N_Q12, 0),
                 *n22 = &NOD(L, i, N_Q22, 0);
    double w[N_NODES], inv[N_NODES];
    int positive = 1;
    for (int m = 0; m < N_NODES; m++) {
        w[m] = c0 - ca * sn[m] - (q0 * n11[m] + q1 * n12[m] + q2 * n22[m]);
        positive &= w[m] > 0.0;
    }
    if (!positive) {
        *tp = 0.0;
        *ap = 0.0;
        return 0;
    }
    for (int m = 0; m < N_NODES; m++) inv[m] = 1.0 / sqrt(w[m]);
    double k = 0.0, g = 0.0, a = 0.0;
    const double *rk = &RULE(L, R_KRONROD, 0), *rg = &RULE(L, R_GAUSS, 0), *g21 = &NOD(L, i, N_G21, 0),
                 *g22 = &NOD(L, i, N_G22, 0);
    for (int m = 0; m < N_NODES; m++) {
        k += rk[m] * inv[m];
        g += rg[m] * inv[m];
        a += rk[m] * inv[m] * (job[J_P1] * g21[m] + job[J_P2] * g22[m]);
    }
    if (f_low < out[O_FMIN]) {
        for (int m = 0; m < N_NODES; m++) {
            double f = c[C_R2R] * (q0 * NOD(L, i, N_S11, m) + q1 * NOD(L, i, N_S12, m) + q2 * NOD(L, i, N_S22, m))
                       - c[C_R2RHO] * w[m] + c[C_G] * sn[m];
            if (f < out[O_FMIN]) {
                out[O_FMIN] = f;
                out[O_BMIN] = c[C_BLO] + (i + 0.5 * (RULE(L, R_NODES, m) + 1.0)) * c[C_W];
            }
        }
    }
    double half = 0.5 * c[C_W];
    *tp = c[C_TIME] * k * half;
    *ap = -c[C_ALPHA] * a * half;
    return fabs(k - g) <= QUAD_RTOL * k;
}

/* Lowers out[O_FMIN] to F at the tabled nodes of panel i within [lo, hi]. */
static void node_f(Leg *L, long i, double lo, double hi) {
    const double *job = L->job, *c = L->c;
    double q0 = job[J_Q0], q1 = job[J_Q1], q2 = job[J_Q2];
    for (int m = 0; m < N_NODES; m++) {
        double b = c[C_BLO] + (i + 0.5 * (RULE(L, R_NODES, m) + 1.0)) * c[C_W];
        if (lo <= b && b <= hi) {
            double w = job[J_C0] - c[C_A] * NOD(L, i, N_SIN, m) - (q0 * NOD(L, i, N_Q11, m) + q1 * NOD(L, i, N_Q12, m) + q2 * NOD(L, i, N_Q22, m));
            see_f(c[C_R2R] * (q0 * NOD(L, i, N_S11, m) + q1 * NOD(L, i, N_S12, m) + q2 * NOD(L, i, N_S22, m)) - c[C_R2RHO] * w
                  + c[C_G] * NOD(L, i, N_SIN, m), b, L->out);
        }
    }
}

/* W (or its difference from the start: difference) and G at the nodes u0[m] + du[m] of the combined panel: the
   forward recurrences of T_n(u0) and of D_n = T_n(u0 + du) - T_n(u0) (see reduced_rolling._w_g), or of T_n(u0 + du)
   alone, over all nodes at once. */
static void w_g_nodes(const Work *w, const double *u0, const double *du, int difference, double *W, double *G) {
    double t_prev[N_NODES], t_cur[N_NODES], d_prev[N_NODES], d_cur[N_NODES], u[N_NODES];
    for (int m = 0; m < N_NODES; m++) u[m] = u0[m] + du[m];
    if (!difference) {
        for (int m = 0; m < N_NODES; m++) {
            t_prev[m] = 1.0;
            t_cur[m] = u[m];
            W[m] = w->wc[0] + w->wc[1] * u[m];
            G[m] = w->gc[0] + w->gc[1] * u[m];
        }
        for (int n = 2; n < N_COEF; n++) {
            double cw = w->wc[n], cg = w->gc[n];
            for (int m = 0; m < N_NODES; m++) {
                double t2 = 2.0 * u[m] * t_cur[m] - t_prev[m];
                W[m] += cw * t2;
                G[m] += cg * t2;
                t_prev[m] = t_cur[m];
                t_cur[m] = t2;
            }
        }
        return;
    }
    for (int m = 0; m < N_NODES; m++) {
        t_prev[m] = 1.0;
        t_cur[m] = u0[m];
        d_prev[m] = 0.0;
        d_cur[m] = du[m];
        W[m] = w->wc[1] * du[m];
        G[m] = w->gc[0] + w->gc[1] * u[m];
    }
    for (int n = 1; n < N_COEF - 1; n++) {
        double cw = w->wc[n + 1], cg = w->gc[n + 1];
        for (int m = 0; m < N_NODES; m++) {
            double d_next = 2.0 * u[m] * d_cur[m] + 2.0 * du[m] * t_cur[m] - d_prev[m];
            double t_next = 2.0 * u0[m] * t_cur[m] - t_prev[m];
            W[m] += cw * d_next;
            G[m] += cg * (t_next + d_next);
            d_prev[m] = d_cur[m];
            d_cur[m] = d_next;
            t_prev[m] = t_cur[m];
            t_cur[m] = t_next;
        }
    }
}

/* Gauss-Kronrod (k), Gauss (g) and alpha (a) sums over theta in [th_a, th_b] (see reduced_rolling._gk). */
static void gk(const Leg *L, double th_a, double th_b, double beta_s, double beta_e, int mode, double ws, double we,
               double near, long i, double *k_out, double *g_out, double *a_out) {
    const double *c = L->c;
    double half = 0.5 * (th_b - th_a), mid = 0.5 * (th_a + th_b);
    double Lb = beta_e - beta_s, aL = fabs(Lb);
    double du_db = 2.0 / c[C_W];
    double slope = mode == 3 ? (we - ws) / Lb : 0.0;
    double u_s = local_u(beta_s, i, c), u_e = local_u(beta_e, i, c);
    double u0[N_NODES], du[N_NODES], jac[N_NODES], delta[N_NODES], W[N_NODES], G[N_NODES];
    int row = -1;
    if (th_a == 0.0 && (mode == 1 || mode == 2) && th_b == 0.5 * M_PI) row = R_SIN_QUARTER;
    else if (th_a == 0.0 && mode == 3 && th_b == M_PI) row = R_SIN_HALF;
    for (int m = 0; m < N_NODES; m++) {
        double th = mid + half * RULE(L, R_NODES, m);
        int from_start;
        if (mode == 0) {
            from_start = 1;
            delta[m] = Lb * th;
            jac[m] = aL;
        } else if (mode >= 4) { /* theta^2 = near + distance from the end next to the singularity */
            from_start = mode == 4;
            delta[m] = (mode == 4) == (Lb > 0.0) ? th * th - near : near - th * th;
            jac[m] = 2.0 * th;
        } else {
            double sh;
            if (row >= 0) {
                sh = RULE(L, row + 1, m);
                jac[m] = aL * RULE(L, row, m);
            } else {
                sh = sin(0.5 * th);
                jac[m] = aL * sin(th);
            }
            if (mode == 1) {
                from_start = 1;
                delta[m] = 2.0 * Lb * sh * sh;
            } else if (mode == 2) {
                from_start = 0;
                delta[m] = -2.0 * Lb * sh * sh;
            } else if (th <= 0.5 * M_PI) {
                from_start = 1;
                delta[m] = Lb * sh * sh;
                jac[m] *= 0.5;
            } else {
                double ch = row >= 0 ? RULE(L, R_SIN_HALF + 2, m) : cos(0.5 * th);
                from_start = 0;
                delta[m] = -Lb * ch * ch;
                jac[m] *= 0.5;
            }
        }
        u0[m] = from_start ? u_s : u_e;
        du[m] = delta[m] * du_db;
    }
    w_g_nodes(&L->work, u0, du, mode >= 1 && mode <= 3, W, G);
    double k = 0.0, g = 0.0, a = 0.0;
    for (int m = 0; m < N_NODES; m++) {
        double w = mode == 3 ? W[m] - slope * delta[m] : W[m];
        if (w > 0.0) {
            double inv = jac[m] / sqrt(w);
            k += RULE(L, R_KRONROD, m) * inv;
            g += RULE(L, R_GAUSS, m) * inv;
            a += RULE(L, R_KRONROD, m) * inv * G[m];
        }
    }
    *k_out = k * half;
    *g_out = g * half;
    *a_out = a * half;
}

/* Time and alpha from beta_s to beta_e on panel i by adaptive Gauss-Kronrod; returns ok. */
static int segment(Leg *L, double beta_s, double beta_e, int sing_s, int sing_e, long i, double *tp, double *ap,
                   long *n_ev) {
    const double *c = L->c;
    *tp = 0.0;
    *ap = 0.0;
    if (beta_e == beta_s) return 1;
    need_gc(L);
    int mode = (sing_s ? 1 : 0) + (sing_e ? 2 : 0);
    double scale = 2.0 / c[C_W];
    double ws = 0.0, we = 0.0, near = 0.0, bottom = 0.0;
    if (mode == 3 || mode == 0) {
        Values vs, ve;
        series_at(L->work.wc, L->work.wd, local_u(beta_s, i, c), scale, &vs.w, &vs.dw);
        series_at(L->work.wc, L->work.wd, local_u(beta_e, i, c), scale, &ve.w, &ve.dw);
        *n_ev += 2;
        ws = vs.w;
        we = ve.w;
        if (mode == 0) { /* W's zero by linear extrapolation, behind the start or beyond the end, nearer than the length */
            double dd = beta_e > beta_s ? 1.0 : -1.0, length = fabs(beta_e - beta_s);
            double near_s = dd * vs.dw > 0.0 ? vs.w / (dd * vs.dw) : INFINITY;
            double near_e = dd * ve.dw < 0.0 ? ve.w / (-dd * ve.dw) : INFINITY;
            if (near_s < NEAR * length && near_s <= near_e && vs.w > 0.0) {
                mode = 4;
                near = near_s;
            } else if (near_e < NEAR * length && ve.w > 0.0) {
                mode = 5;
                near = near_e;
            }
        }
    }
    double top = mode == 3 ? M_PI : (mode == 1 || mode == 2 ? 0.5 * M_PI : 1.0);
    if (mode >= 4) {
        bottom = sqrt(near);
        top = sqrt(fabs(beta_e - beta_s) + near);
    }
    double k, g, a;
    gk(L, bottom, top, beta_s, beta_e, mode, ws, we, near, i, &k, &g, &a);
    *n_ev += N_NODES;
    if (fabs(k - g) <= QUAD_RTOL * fabs(k)) {
        *tp = c[C_TIME] * k;
        *ap = -c[C_ALPHA] * a;
        return 1;
    }
    double tol = QUAD_RTOL * fabs(k);
    double (*stack)[2] = L->stack;
    stack[0][0] = bottom;
    stack[0][1] = top;
    int n_st = 1;
    double k_sum = 0.0, a_sum = 0.0;
    int ok = 0;
    for (int it = 0; it < MAX_QUAD; it++) {
        if (n_st == 0) {
            ok = 1;
            break;
        }
        n_st--;
        double lo = stack[n_st][0], hi = stack[n_st][1], mid = 0.5 * (lo + hi);
        int full = 0;
        for (int side = 0; side < 2; side++) {
            double x0 = side == 0 ? lo : mid, x1 = side == 0 ? mid : hi;
            gk(L, x0, x1, beta_s, beta_e, mode, ws, we, near, i, &k, &g, &a);
            *n_ev += N_NODES;
            if (fabs(k - g) <= tol || x1 - x0 < 1e-14 * (top - bottom)) {
                k_sum += k;
                a_sum += a;
            } else if (n_st >= MAX_STACK) {
                full = 1;
                break;
            } else {
                stack[n_st][0] = x0;
                stack[n_st][1] = x1;
                n_st++;
            }
        }
        if (full) break;
    }
    *tp = c[C_TIME] * k_sum;
    *ap = -c[C_ALPHA] * a_sum;
    return ok;
}

/* (W, dW/dbeta, F, dF/dbeta) at beta (combining its panel's series if needed). */
static Values slope_f(Leg *L, double beta) {
    long i = panel_of(beta, 1.0, L->c);
    combine(L, i);
    need_fd(&L->work);
    return values_at(&L->work, local_u(beta, i, L->c), 2.0 / L->c[C_W]);
}

/* Lowers out[O_FMIN] to the minimum of F near beta (Illinois on dF/dbeta within +-0.15 panel, inside [lo, hi]). */
static void refine_min(Leg *L, double beta, double lo, double hi) {
    const double *c = L->c;
    double a = fmax(beta - 0.15 * c[C_W], lo), b = fmin(beta + 0.15 * c[C_W], hi);
    double ga = slope_f(L, a).df, gb = slope_f(L, b).df;
    if (!(ga < 0.0 && 0.0 < gb)) return;
    int side = 0;
    double m = 0.5 * (a + b);
    for (int it = 0; it < MAX_NEWTON; it++) {
        if (b - a < 1e-7 * c[C_W]) break;
        m = (a * gb - b * ga) / (gb - ga);
        if (!(a < m && m < b)) m = 0.5 * (a + b);
        double gm = slope_f(L, m).df;
        if (gm < 0.0) {
            a = m;
            ga = gm;
            if (side == -1) gb *= 0.5;
            side = -1;
        } else {
            b = m;
            gb = gm;
            if (side == 1) ga *= 0.5;
            side = 1;
        }
        if (fabs(gm) == 0.0 || fabs(b - a) < 1e-7 * c[C_W]) break;
    }
    L->out[O_FMIN] = fmin(L->out[O_FMIN], slope_f(L, m).f);
}

/* One leg (reduced_rolling._leg). */
static void leg(Leg *L) {
    const double *job = L->job, *c = L->c;
    double *out = L->out;
    double beta = job[J_BETA], d = job[J_DIR], stop = job[J_STOP];
    int sing = job[J_SING] > 0.0;
    L->work.panel = -1;
    out[O_FMIN] = INFINITY;
    out[O_BMIN] = beta;
    double t = 0.0, alpha = 0.0;
    int ok = 1, first = 1, kind = EV_CAP;
    long n_ev = 0;
    long npan = n_panels(L);
    long i = panel_of(beta, d, c);
    for (long it = 0; it < npan + 2; it++) {
        if (i < 0 || i >= npan || !isfinite(beta)) {
            kind = EV_FAIL;
            break;
        }
        double edge = d > 0 ? c[C_BLO] + (i + 1) * c[C_W] : c[C_BLO] + i * c[C_W];
        int at_stop = d * (stop - edge) <= 0.0;
        double tp, ap, f_low;
        if (!first && !at_stop && clear_panel(L, i, &f_low)) {
            int good = full_panel(L, i, f_low, &tp, &ap);
            n_ev += N_NODES;
            if (good) {
                t += tp;
                alpha += ap;
                beta = edge;
                i += d > 0 ? 1 : -1;
                continue;
            }
        }
        combine(L, i);
        double end = at_stop ? stop : edge;
        if (first) {
            see_f(value_at(L->work.fc, local_u(beta, i, c)), beta, out);
            n_ev++;
        }
        int ev = EV_NONE;
        double b_e = end;
        if (!(L->work.lw > 0.0 && L->work.lf > 0.0 && !(first && sing))) {
            ev = isolate(L, beta, end, d, i, first && sing, &b_e, &n_ev);
            if (ev == EV_CAP) {
                kind = EV_CAP;
                break;
            }
        }
        int good = 0;
        if (!first && ev == EV_NONE && !at_stop) {
            good = full_panel(L, i, L->work.lf, &tp, &ap);
            n_ev += N_NODES;
        } else {
            node_f(L, i, fmin(beta, b_e), fmax(beta, b_e));
        }
        if (!good) good = segment(L, beta, b_e, first && sing, ev == EV_TURN, i, &tp, &ap, &n_ev);
        t += tp;
        alpha += ap;
        ok = ok && good;
        if (ev != EV_NONE || at_stop) {
            kind = ev != EV_NONE ? ev : EV_STOP;
            beta = b_e;
            if (ev != EV_FALL) see_f(value_at(L->work.fc, local_u(beta, i, c)), beta, out);
            break;
        }
        beta = edge;
        first = 0;
        i += d > 0 ? 1 : -1;
    }
    out[O_KIND] = kind;
    out[O_BETA] = beta;
    out[O_T] = t;
    out[O_ALPHA] = alpha;
    out[O_EVALS] = (double)n_ev;
    out[O_OK] = ok ? 1.0 : 0.0;
}

/* Refines out[O_FMIN] of a finished leg within its range (reduced_rolling._leg_fmin). */
static void leg_fmin(Leg *L) {
    const double *job = L->job;
    double *out = L->out;
    double lo = fmin(job[J_BETA], out[O_BETA]), hi = fmax(job[J_BETA], out[O_BETA]);
    if (hi > lo && out[O_FMIN] > 0.0 && lo < out[O_BMIN] && out[O_BMIN] < hi) refine_min(L, out[O_BMIN], lo, hi);
}

/* The legs of the m job rows into out; returns 0. */
int rimroll_exact_legs(long m, const double *jobs, const double *tab, const double *nod, const double *spread,
                       const double *c, const double *rule, double *out) {
    Leg *L = (Leg *)PyMem_RawMalloc(sizeof(Leg));
    if (L == NULL) return -1;
    L->tab = tab;
    L->nod = nod;
    L->spread = spread;
    L->c = c;
    L->rule = rule;
    for (long n = 0; n < m; n++) {
        L->job = jobs + (size_t)n * N_J;
        L->out = out + (size_t)n * N_O;
        leg(L);
        leg_fmin(L);
    }
    PyMem_RawFree(L);
    return 0;
}

/* Values out (nf, n) of the tabled functions funcs (nf) at the points beta (n) [rad]: reduced_tables.evaluate_many.
   Points go in blocks of EVAL_BLOCK, so that the recurrences of T_n of a block run side by side. */
#define EVAL_BLOCK 8
int rimroll_exact_evaluate(long n, const double *beta, const double *tab, long n_pan, double beta_lo, double width,
                           const long *funcs, int nf, double *out) {
    for (long p0 = 0; p0 < n; p0 += EVAL_BLOCK) {
        int nb = n - p0 < EVAL_BLOCK ? (int)(n - p0) : EVAL_BLOCK;
        long idx[EVAL_BLOCK];
        double t[N_COEF][EVAL_BLOCK];
        for (int b = 0; b < EVAL_BLOCK; b++) {
            double x = beta[p0 + (b < nb ? b : 0)];
            double y = floor((x - beta_lo) / width);
            long i = isfinite(y) ? (long)fmin(fmax(y, 0.0), (double)(n_pan - 1)) : 0;
            idx[b] = i;
            t[0][b] = 1.0;
            t[1][b] = 2.0 * (x - beta_lo - i * width) / width - 1.0;
        }
        for (int k = 2; k < N_COEF; k++)
            for (int b = 0; b < EVAL_BLOCK; b++) t[k][b] = 2.0 * t[1][b] * t[k - 1][b] - t[k - 2][b];
        for (int f = 0; f < nf; f++) {
            for (int b = 0; b < nb; b++) {
                const double *cf = tab + ((size_t)idx[b] * N_FUNCTIONS + funcs[f]) * N_COEF;
                double v = 0.0;
                for (int k = 0; k < N_COEF; k++) v += cf[k] * t[k][b];
                out[(size_t)f * n + p0 + b] = v;
            }
        }
    }
    return 0;
}

/* The layout this library was compiled for, in the order reduced_legs checks it. */
int rimroll_exact_layout(long *dims, int n) {
    long mine[] = {N_COEF, N_NODES, N_FUNCTIONS, N_NODE_ROWS, N_SPREAD, N_J, N_O, N_C, N_RULE,
                   Q11, Q12, Q22, S11, S12, S22, SIN, G21, G22, MAX_STACK, MAX_MARCH, MAX_QUAD, MAX_NEWTON};
    int k = (int)(sizeof(mine) / sizeof(mine[0]));
    for (int j = 0; j < n && j < k; j++) dims[j] = mine[j];
    return k;
}

/* The tolerances this library was compiled with: H_MIN [rad], QUAD_RTOL, NEAR. */
int rimroll_exact_tolerances(double *v, int n) {
    double mine[] = {H_MIN, QUAD_RTOL, NEAR};
    int k = (int)(sizeof(mine) / sizeof(mine[0]));
    for (int j = 0; j < n && j < k; j++) v[j] = mine[j];
    return k;
}

static struct PyModuleDef module = {PyModuleDef_HEAD_INIT, "_exact_legs",
                                    "Exact rolling legs compiled at install (solver/engine/_exact_legs.c); "
                                    "called through ctypes by reduced_legs.",
                                    -1, NULL, NULL, NULL, NULL, NULL};

PyMODINIT_FUNC PyInit__exact_legs(void) { return PyModule_Create(&module); }
