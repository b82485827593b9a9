"""Per-trajectory scene kernels: one compiled function per scene, and the chunk driver.

A scene (DESIGN §3) is fixed at compile time by two flags closed over by
:func:`_make_trajectory`: ``hybrid`` (finite mu: rolling/slipping switching of Sect. 5.2.2) and
``conservative`` (k_r = k_d = 0: periodic detection, Prop. 4). numba freezes closure variables
as constants, so each scene's kernel carries only its own branches.

A run is a loop over phases (rolling or slipping). A phase starts with its checks (F2 < 0:
fall now; rolling outside the friction cone: slip now), takes accepted steps of the generic RK
stepper, and scans each step's dense output for events (``solver.events``). The transitions are
the pure maps of ``solver.switching`` applied between phases; the stepper restarts (new initial
step, new first stage) after each. Every failure is recorded in ``status``; nothing raises.

Results go to one row of ``res_f`` (float64, ``RF_*`` columns) and ``res_i`` (int64, ``RI_*``).
"""

from __future__ import annotations

import numpy as np

from solver._compile import kernel
from solver.events import initial_signs, locate, may_cross, scan, update_signs
from solver.flight import flight_outcome
from solver.outcomes import (
    MAX_STEPS,
    NON_FINITE,
    ON_RIM_AT_T_MAX,
    OK,
    PERIODIC_ROLLING,
    STEP_SIZE_UNDERFLOW,
    TOO_MANY_SWITCHES,
)
from solver.params import P_G, P_J, P_M, P_R_BALL, P_R_RIM, P_RHO
from solver.rolling import rolling_rhs
from solver.stepper import (
    MIN_FACTOR,
    dense_eval,
    dense_prepare,
    error_norm,
    initial_step,
    min_step,
    rk_step,
    step_factor,
)
from solver.switching import enter_slipping, try_return
from solver.system import (
    EV_FALL,
    EV_OMEGA1,
    EV_SWITCH,
    I_U1,
    I_U3,
    N_EVENTS,
    N_MAX,
    N_ROLLING,
    N_SLIPPING,
    ROLLING,
    ROLLING_DIRECTION,
    SLIPPING,
    SLIPPING_DIRECTION,
    event_rates,
    event_values,
    event_values_rates,
    rhs,
    state_energy,
)

# Result columns.
RF_T_END, RF_F2_MIN, RF_HALF_PERIOD, RF_REVOLUTIONS, RF_SLIP_TIME, RF_ENERGY_DRIFT = 0, 1, 2, 3, 4, 5
RF_BETA, RF_OMEGA1, RF_OMEGA2, RF_OMEGA3 = 6, 7, 8, 9
N_RF = 10
RI_OUTCOME, RI_SLIP_PHASES, RI_N_STEPS, RI_STATUS = 0, 1, 2, 3
N_RI = 4

TRANSVERSAL_EPS = 1e3 * np.finfo(np.float64).eps
"""An omega1 zero counts as a transversal crossing (Prop. 4, DESIGN §4) only if |omega1_dot|
there exceeds TRANSVERSAL_EPS times the summed magnitudes of the terms of (33): about 1000
times the round-off of (33) at an exact steady motion (whose omega1 = 0 'crossings' are sign
flips of round-off noise), and far below any orbit an integration can resolve."""


@kernel
def transversal_omega1_zero(y, p):
    """Whether an omega1 zero of the rolling state y crosses transversally (see TRANSVERSAL_EPS)."""
    beta, w1, w2, w3 = y[0], y[1], y[2], y[3]
    r = p[P_R_BALL]
    j = p[P_J]
    c = np.cos(beta)
    D = p[P_R_RIM] - p[P_RHO] * c
    scale = (abs(r * w3 * w3 * np.sin(beta) / D) + abs(j * r * w2 * w3 * c / ((1.0 + j) * D))
             + abs(p[P_G] * c / (r * (1.0 + j))))
    _, w1_dot, _, _ = rolling_rhs(beta, w1, w2, w3, p)
    return abs(w1_dot) > TRANSVERSAL_EPS * scale


# Scenes.
SCENE_ROLLING_CONSERVATIVE = 0
SCENE_ROLLING_DISSIPATIVE = 1
SCENE_HYBRID_CONSERVATIVE = 2
SCENE_HYBRID_DISSIPATIVE = 3

MAX_NONFINITE_RETRIES = 30  # consecutive non-finite trial steps (each cutting h by MIN_FACTOR)

_W_ROWS = 7  # work vectors: y, y_new, f, tmp, y_ev, f1, y_hi
_G_ROWS = 7  # event vectors: g (step start), g_lo, g_hi, g_ev, g_tmp, gr (rates at start), gr_hi (at end)


def _make_trajectory(hybrid, conservative):
    HYBRID = hybrid
    CONSERVATIVE = conservative

    def trajectory(x0, p, t_max, rtol, atol, A, E, P, n_stages, err_mode, error_order, max_steps,
                   max_switches, sw, active, direction, W, K, Q, G, sign, res_f, res_i):
        n_dense = A.shape[0]
        n_poly = P.shape[1]
        exponent = -1.0 / (error_order + 1.0)
        y = W[0]
        y_new = W[1]
        f = W[2]
        tmp = W[3]
        y_ev = W[4]
        f1 = W[5]
        y_hi = W[6]
        g = G[0]
        g_lo = G[1]
        g_hi = G[2]
        g_ev = G[3]
        g_tmp = G[4]
        gr = G[5]
        gr_hi = G[6]

        for i in range(4):
            y[i] = x0[i]
        y[4] = 0.0
        phase = ROLLING
        n = N_ROLLING
        t = 0.0
        E0 = state_energy(ROLLING, y, p)
        f2_min = np.inf
        status = OK
        outcome = ON_RIM_AT_T_MAX
        n_steps = 0
        switches = 0
        slip_phases = 0
        slip_time = 0.0
        t_slip0 = 0.0
        half_period = np.nan
        n_cross = 0
        t1 = 0.0
        fresh = True
        h = 0.0
        after_reject = False
        n_bad = 0
        dt_return = -1.0
        act = active[ROLLING]  # the active events and directions of the phase (set at its start)
        dirn = direction[ROLLING]

        while True:
            # ---------------- start of a phase ----------------
            if fresh:
                event_values(phase, HYBRID, y, p, sw, g)
                finite = True
                for i in range(n):
                    if not np.isfinite(y[i]):
                        finite = False
                for e in range(N_EVENTS):
                    if not np.isfinite(g[e]):
                        finite = False
                if not finite:
                    status = NON_FINITE
                    break
                f2_min = min(f2_min, g[EV_FALL])
                if g[EV_FALL] < 0.0:
                    if phase == ROLLING:
                        outcome = flight_outcome(y[0], y[1], y[3], 0.0, 0.0, p)
                    else:
                        outcome = flight_outcome(y[0], y[1], y[3], y[I_U1], y[I_U3], p)
                    break
                if HYBRID and phase == ROLLING and g[EV_SWITCH] < 0.0:
                    switches += 1
                    if switches > max_switches:
                        status = TOO_MANY_SWITCHES
                        break
                    enter_slipping(y, p, sw)
                    phase = SLIPPING
                    n = N_SLIPPING
                    slip_phases += 1
                    t_slip0 = t
                    continue
                act = active[phase]
                dirn = direction[phase]
                initial_signs(g, dirn, sign)
                if CONSERVATIVE and phase == ROLLING:
                    n_cross = 0
                    if y[1] == 0.0 and transversal_omega1_zero(y, p):
                        n_cross = 1
                        t1 = t
                if t >= t_max:
                    break
                rhs(phase, y, p, f)
                for i in range(n):
                    if not np.isfinite(f[i]):
                        finite = False
                if not finite:
                    status = NON_FINITE
                    break
                event_rates(phase, HYBRID, y, f, p, sw, gr)
                h = initial_step(phase, y, f, n, n - 1, error_order, rtol, atol, t_max - t, tmp, f1, p)
                after_reject = False
                n_bad = 0
                fresh = False

            # ---------------- one step ----------------
            if t >= t_max:
                break
            if n_steps >= max_steps:
                status = MAX_STEPS
                break
            last = False
            if h >= t_max - t:
                h = t_max - t
                last = True
            if not (h >= min_step(t)):
                status = STEP_SIZE_UNDERFLOW
                break
            n_steps += 1
            rk_step(phase, t, y, f, h, n, A, n_stages, K, y_new, tmp, p)
            err = error_norm(K, E, err_mode, n_stages, h, y, y_new, n - 1, rtol, atol)
            finite = np.isfinite(err)
            for i in range(n):
                if not np.isfinite(y_new[i]) or not np.isfinite(K[n_stages, i]):
                    finite = False
            if not finite:
                n_bad += 1
                if n_bad > MAX_NONFINITE_RETRIES:
                    status = NON_FINITE
                    break
                h *= MIN_FACTOR
                after_reject = True
                continue
            n_bad = 0
            if err > 1.0:
                h *= step_factor(err, exponent, after_reject)
                after_reject = True
                continue
            h_next = h * step_factor(err, exponent, after_reject)
            after_reject = False
            for i in range(n):  # the FSAL slope of y_new (the slope of y is in K[0])
                f[i] = K[n_stages, i]

            # ---------------- events on the dense output ----------------
            # the end values and slopes first: most steps cannot hold an event (events.may_cross)
            event_values_rates(phase, HYBRID, y_new, f, p, sw, g_hi, gr_hi)
            done = False  # the run ends at the event
            switch = False  # the phase ends at the event
            scanned = may_cross(act, sign, g, gr, g_hi, gr_hi, h, f2_min)
            if scanned:
                dense_prepare(phase, y, h, n, A, n_stages, n_dense, P, n_poly, K, Q, tmp, p)
                for e in range(N_EVENTS):
                    g_ev[e] = g[e]
            else:
                f2_min = min(f2_min, g_hi[EV_FALL])
                update_signs(g_hi, sign, -1)
            theta0 = 0.0
            while scanned:
                f2_theta0 = g_ev[EV_FALL]
                ev, theta, fmin = scan(phase, HYBRID, act, dirn, sign, theta0, g_ev, y,
                                       y_new, h, t, Q, n, n_poly, p, sw, y_hi, g_lo, g_hi, tmp, g_tmp)
                f2_min = min(f2_min, fmin)
                if ev < 0:
                    break
                if theta >= 1.0:
                    for i in range(n):
                        y_ev[i] = y_new[i]
                else:
                    dense_eval(theta, y, h, Q, n, n_poly, y_ev)
                event_values(phase, HYBRID, y_ev, p, sw, g_ev)
                if ev != EV_FALL and g_ev[EV_FALL] < 0.0 and f2_theta0 >= 0.0:
                    # F2 went below 0 between the samples before this event: the ball left the
                    # rim first (at a deadlock the dip is centred on the omega1 zero, by (61))
                    theta = locate(phase, HYBRID, EV_FALL, theta0, f2_theta0, theta, g_ev[EV_FALL], y, h, t,
                                   Q, n, n_poly, p, sw, tmp, g_tmp)
                    dense_eval(theta, y, h, Q, n, n_poly, y_ev)
                    event_values(phase, HYBRID, y_ev, p, sw, g_ev)
                    ev = EV_FALL
                f2_min = min(f2_min, g_ev[EV_FALL])
                t_ev = t + theta * h
                if ev == EV_FALL:
                    if phase == ROLLING:
                        outcome = flight_outcome(y_ev[0], y_ev[1], y_ev[3], 0.0, 0.0, p)
                    else:
                        outcome = flight_outcome(y_ev[0], y_ev[1], y_ev[3], y_ev[I_U1], y_ev[I_U3], p)
                    done = True
                elif ev == EV_OMEGA1:
                    if not transversal_omega1_zero(y_ev, p):
                        pass  # a touching zero (round-off at a steady motion) is no crossing
                    elif n_cross == 0:
                        n_cross = 1
                        t1 = t_ev
                    else:
                        outcome = PERIODIC_ROLLING
                        half_period = t_ev - t1
                        done = True
                elif phase == ROLLING:  # EV_SWITCH: the friction cone is left
                    switch = True
                else:  # EV_SWITCH: the slip speed reached u_stop
                    dt_return = try_return(y_ev, p, sw, t_max - t_ev, y_hi)
                    switch = dt_return >= 0.0
                if done or switch:
                    for i in range(n):
                        y[i] = y_ev[i]
                    t = t_ev
                    break
                sign[ev] = -sign[ev]
                update_signs(g_ev, sign, ev)
                theta0 = theta
            if done:
                break

            if not switch:
                # the step is taken in full
                t = t_max if last else t + h
                for i in range(n):
                    y[i] = y_new[i]
                for e in range(N_EVENTS):
                    g[e] = g_hi[e]
                    gr[e] = gr_hi[e]
                h = h_next
                if phase == SLIPPING:
                    dt_return = try_return(y, p, sw, t_max - t, y_hi)
                    switch = dt_return >= 0.0
            if switch:
                switches += 1
                if switches > max_switches:
                    status = TOO_MANY_SWITCHES
                    break
                if phase == ROLLING:
                    enter_slipping(y, p, sw)
                    phase = SLIPPING
                    n = N_SLIPPING
                    slip_phases += 1
                    t_slip0 = t
                else:  # y_hi holds the rolling state of the return
                    for i in range(N_ROLLING):
                        y[i] = y_hi[i]
                    t += dt_return
                    slip_time += t - t_slip0
                    phase = ROLLING
                    n = N_ROLLING
                fresh = True

        # ---------------- record ----------------
        if phase == SLIPPING:
            slip_time += t - t_slip0
        E1 = state_energy(phase, y, p)
        scale = max(abs(E0), p[P_M] * p[P_G] * p[P_RHO])
        res_f[RF_T_END] = t
        res_f[RF_F2_MIN] = f2_min
        res_f[RF_HALF_PERIOD] = half_period
        res_f[RF_REVOLUTIONS] = y[n - 1] / (2.0 * np.pi)
        res_f[RF_SLIP_TIME] = slip_time
        res_f[RF_ENERGY_DRIFT] = abs(E1 - E0) / scale
        res_f[RF_BETA] = y[0]
        res_f[RF_OMEGA1] = y[1]
        res_f[RF_OMEGA2] = y[2]
        res_f[RF_OMEGA3] = y[3]
        res_i[RI_OUTCOME] = outcome
        res_i[RI_SLIP_PHASES] = slip_phases
        res_i[RI_N_STEPS] = n_steps
        res_i[RI_STATUS] = status

    # One name per scene: the four closures would otherwise share a qualname (and source line),
    # so numba's disk cache could file their machine code under one key and load one scene's
    # code for another (numba issue #10486; seen in the shared checkout, see
    # tests/test_reference_hybrid.py).
    name = "trajectory_%s_%s" % ("hybrid" if hybrid else "rolling", "conservative" if conservative else "dissipative")
    trajectory.__name__ = name
    trajectory.__qualname__ = name
    return kernel(trajectory)


_trajectory_rolling_conservative = _make_trajectory(False, True)
_trajectory_rolling_dissipative = _make_trajectory(False, False)
_trajectory_hybrid_conservative = _make_trajectory(True, True)
_trajectory_hybrid_dissipative = _make_trajectory(True, False)


@kernel
def run_chunk(scene, states, p, t_max, rtol, atol, A, E, P, n_stages, err_mode, error_order, max_steps,
              max_switches, sw, res_f, res_i):
    """Simulate every row of ``states`` (m, 4) in the given scene; results into rows of res_f, res_i."""
    hybrid = scene == SCENE_HYBRID_CONSERVATIVE or scene == SCENE_HYBRID_DISSIPATIVE
    conservative = scene == SCENE_ROLLING_CONSERVATIVE or scene == SCENE_HYBRID_CONSERVATIVE
    W = np.zeros((_W_ROWS, N_MAX))
    K = np.zeros((A.shape[0], N_MAX))
    Q = np.zeros((N_MAX, P.shape[1]))
    G = np.zeros((_G_ROWS, N_EVENTS))
    sign = np.zeros(N_EVENTS, dtype=np.int64)
    direction = np.empty((2, N_EVENTS), dtype=np.int64)
    active = np.ones((2, N_EVENTS), dtype=np.bool_)
    for e in range(N_EVENTS):
        direction[ROLLING, e] = ROLLING_DIRECTION[e]
        direction[SLIPPING, e] = SLIPPING_DIRECTION[e]
    active[ROLLING, EV_SWITCH] = hybrid
    active[ROLLING, EV_OMEGA1] = conservative
    active[SLIPPING, EV_OMEGA1] = False
    for k in range(states.shape[0]):
        x0 = states[k]
        if scene == SCENE_ROLLING_CONSERVATIVE:
            _trajectory_rolling_conservative(x0, p, t_max, rtol, atol, A, E, P, n_stages, err_mode, error_order,
                                             max_steps, max_switches, sw, active, direction, W, K, Q, G, sign,
                                             res_f[k], res_i[k])
        elif scene == SCENE_ROLLING_DISSIPATIVE:
            _trajectory_rolling_dissipative(x0, p, t_max, rtol, atol, A, E, P, n_stages, err_mode, error_order,
                                            max_steps, max_switches, sw, active, direction, W, K, Q, G, sign,
                                            res_f[k], res_i[k])
        elif scene == SCENE_HYBRID_CONSERVATIVE:
            _trajectory_hybrid_conservative(x0, p, t_max, rtol, atol, A, E, P, n_stages, err_mode, error_order,
                                            max_steps, max_switches, sw, active, direction, W, K, Q, G, sign,
                                            res_f[k], res_i[k])
        else:
            _trajectory_hybrid_dissipative(x0, p, t_max, rtol, atol, A, E, P, n_stages, err_mode, error_order,
                                           max_steps, max_switches, sw, active, direction, W, K, Q, G, sign,
                                           res_f[k], res_i[k])
