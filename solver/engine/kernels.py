"""Per-trajectory scene kernels and the chunk driver of ``solver.simulate``.

A scene (docs/outcome-engine.md) is fixed by two flags, ``hybrid`` (finite mu:
rolling/slipping switching of Sect. 5.2.2) and ``conservative`` (k_r = k_d = 0: periodic
detection, Prop. 4). Each scene has its own named kernel (``scene_rolling_conservative``, ...)
that runs a chunk of initial states through the inlined bodies :func:`run_scene` and
:func:`trajectory` with its flags as literals, so a rolling-only kernel holds no slipping phase
at all, and a process compiles only the scenes it runs. The step loop of a phase,
:func:`run_phase`, is the expensive part of the first compile (~7 s of CPU per specialisation)
and has three: rolling with and without the friction-cone events (``hybrid`` literal: the cone
needs the contact forces at every step), slipping once (only hybrid scenes slip);
``conservative`` (one sign test of omega1 per step) is a run-time argument there.

Functions that take a compiled function as an argument (``run_phase``, the event locator, the
stepper's helpers) are not cached on their own (``solver._compile``): numba keys a cache entry
on the argument's type, which names one process's function object, so such an entry never hits
in another process and re-saving the index can fail. Their machine code is cached inside the
scene kernels, which take arrays and numbers only.

A trajectory is a loop over phases and reads as the rules do (``solver.engine.rules``):

1. phase-start checks (F2 < 0: fall now; rolling outside the friction cone: slip now; the
   initial state on a steady motion: ``steady_motion``);
2. run one phase (:func:`run_phase`) to its terminal event: steps of the generic stepper
   (``solver.engine.stepper.attempt``), each searched for events on its dense output
   (``solver.engine.events``) when the gate asks for it;
3. apply the event's action from the phase's event table (``solver.engine.system``): fall (free
   flight), periodic orbit, switch to slipping (``switching.enter_slipping``) or back to
   rolling (``switching.try_return``).

Every failure is recorded in ``status``; nothing raises. A step budget spent mostly in slip
phases is ``stiff_slip`` rather than ``max_steps`` (``RI_N_SLIP_STEPS`` counts those steps). Results go to one row of ``res_f``
(float64, ``RF_*`` columns) and ``res_i`` (int64, ``RI_*``).
"""

from __future__ import annotations

import numpy as np

from rimroll.solver.physics import rolling, slipping

from rimroll.solver.engine import rules, system
from rimroll.solver._compile import kernel
from rimroll.solver.engine.events import fires, hermite_at, initial_signs, next_event, trough_possible, update_signs, value_at
from rimroll.solver.engine.outputs import FLOAT_COLUMNS, INT_COLUMNS, column
from rimroll.solver.engine.outcomes import (
    MAX_STEPS,
    NON_FINITE,
    OK,
    ON_RIM_AT_T_MAX,
    PERIODIC_ROLLING,
    STEADY_MOTION,
    STEP_SIZE_UNDERFLOW,
    STIFF_SLIP,
    TOO_MANY_SWITCHES,
)
from rimroll.solver.physics.params import P_G, P_M, P_RHO
from rimroll.solver.engine.stepper import ACCEPTED, BUDGET_SPENT, UNDERFLOW, attempt, dense_eval, dense_prepare, initial_step
from rimroll.solver.physics.switching import enter_slipping, try_return
from rimroll.solver.engine.system import (
    ACT_FALL,
    ACT_OMEGA1,
    ACT_RETURN,
    ACT_SLIP,
    EV_FALL,
    I_U1,
    I_U3,
    N_EVENTS,
    N_MAX,
    N_ROLLING,
    N_SLIPPING,
)

# Result columns (solver.engine.outputs): float64 outputs in res_f, integer ones in res_i.
RF_T_END, RF_F2_MIN, RF_HALF_PERIOD = column("t_end"), column("f2_min"), column("half_period")
RF_REVOLUTIONS, RF_SLIP_TIME, RF_ENERGY_DRIFT = column("revolutions"), column("slip_time"), column("energy_drift")
RF_BETA, RF_OMEGA1, RF_OMEGA2, RF_OMEGA3 = (column(f"{x}_end") for x in ("beta", "omega1", "omega2", "omega3"))
N_RF = len(FLOAT_COLUMNS)
RI_OUTCOME, RI_SLIP_PHASES, RI_N_STEPS = column("outcome"), column("slip_phases"), column("n_steps")
RI_STATUS, RI_N_SEARCHED, RI_N_SLIP_STEPS = column("status"), column("n_searched"), column("n_slip_steps")
N_RI = len(INT_COLUMNS)

# How a phase ends (run_phase).
END_T_MAX = 0
END_FALL = 1
END_PERIODIC = 2
END_SWITCH = 3
END_FAILED = 4

# Work rows.
W_Y, W_Y_NEW, W_F, W_TMP, W_Y_EV, W_SLOPE, W_Y_RET, W_F_NEW, W_ATOL_ROLL, W_ATOL_SLIP = range(10)
N_W = 10
G_G, G_GR, G_G1, G_GR1, G_EV, G_LO, G_HI, G_TMP, G_RTMP, G_MIN, G_TH, G_THIRD = range(12)
N_G = 12


@kernel(takes_functions=True)
def run_phase(rhs, events, rolling_phase, hybrid, conservative, direction, track_min, action, active, n, p, sw,
              t_max, rtol, atol_vec, A, E, P, n_stages, err_mode, error_order, max_steps, W, K, Q, G, sign, search,
              res_f, res_i):
    """Run one phase from the state W[W_Y] at time res_f[RF_T_END] to its terminal event.

    rhs, events: the phase's right-hand side and event function (``solver.engine.system``);
    direction, track_min, action, active: its event table; atol_vec: its absolute tolerance per
    component (``system.*_atol``). Returns (how the phase ends: END_*,
    the time of a return to rolling [s] or -1). On END_SWITCH of a slipping phase W[W_Y_RET]
    holds the rolling state of the return; on END_FALL res_i[RI_OUTCOME] is set; on END_PERIODIC
    res_f[RF_HALF_PERIOD]; on END_FAILED res_i[RI_STATUS].
    """
    n_dense = A.shape[0]
    n_poly = P.shape[1]
    exponent = -1.0 / (error_order + 1.0)
    y = W[W_Y]
    y_new = W[W_Y_NEW]
    f = W[W_F]
    tmp = W[W_TMP]
    y_ev = W[W_Y_EV]
    slope = W[W_SLOPE]  # scratch: slopes of the dense output
    f_new = W[W_F_NEW]
    y_ret = W[W_Y_RET]
    g = G[G_G]
    gr = G[G_GR]
    g1 = G[G_G1]
    gr1 = G[G_GR1]
    g_ev = G[G_EV]
    mins = G[G_MIN]
    th_min = G[G_TH]
    third_prev = G[G_THIRD]
    t = res_f[RF_T_END]
    n_steps = res_i[RI_N_STEPS]
    n_searched = res_i[RI_N_SEARCHED]

    rhs(y, p, K, 0)
    for i in range(n):
        f[i] = K[0, i]
        if not np.isfinite(f[i]):
            res_i[RI_STATUS] = NON_FINITE
            return END_FAILED, -1.0
    events(y, f, p, sw, hybrid, g, gr)
    initial_signs(g, direction, sign)
    for e in range(N_EVENTS):
        third_prev[e] = np.nan
    n_cross = 0
    t1 = 0.0
    if conservative and rolling_phase and y[1] == 0.0 and rules.transversal_omega1_zero(y[0], y[1], y[2], y[3], p,
                                                                                          rtol):
        n_cross = 1
        t1 = t
    h = initial_step(rhs, y, f, n, n - 1, error_order, rtol, atol_vec, t_max - t, tmp, K, p)
    h_prev = h
    after_reject = False
    end = END_T_MAX
    dt_return = -1.0
    while t < t_max:
        code, h, h_next, attempts, last = attempt(rhs, t, t_max, y, f, h, after_reject, n, n - 1, A, E, n_stages,
                                                  err_mode, exponent, rtol, atol_vec, max_steps - n_steps, K, y_new,
                                                  tmp, p)
        n_steps += attempts
        if code != ACCEPTED:
            res_i[RI_STATUS] = MAX_STEPS if code == BUDGET_SPENT else (
                STEP_SIZE_UNDERFLOW if code == UNDERFLOW else NON_FINITE)
            end = END_FAILED
            break
        for i in range(n):  # the FSAL slope of y_new (the slope of y is in K[0])
            f_new[i] = K[n_stages, i]
        events(y_new, f_new, p, sw, hybrid, g1, gr1)

        # the gate: does the step need its dense output searched?
        searched = False
        prepared = False
        for e in range(N_EVENTS):
            search[e] = False
            if not active[e]:
                continue
            at_end = fires(e, sign, g1[e], active, direction)
            if at_end or not np.isfinite(gr1[e]):
                searched = True
            if track_min[e]:
                mid_err = 0.0
                if not np.isfinite(third_prev[e]):  # first step of the phase: measure the remainder
                    if not prepared:
                        dense_prepare(rhs, y, h, n, A, n_stages, n_dense, P, n_poly, K, Q, tmp, p)
                        prepared = True
                    g_mid = value_at(events, e, 0.5, y, h, Q, n, n_poly, p, sw, hybrid, tmp, slope, G[G_TMP],
                                     G[G_RTMP])
                    mid_err = abs(g_mid - hermite_at(g[e], gr[e], g1[e], gr1[e], h, 0.5))
                want, lo, th_lo, third = trough_possible(g[e], gr[e], g1[e], gr1[e], h, h_prev, third_prev[e],
                                                         mid_err, rtol)
                third_prev[e] = third
                th_min[e] = th_lo
                # a crossing at the end with no interior trough of H: locate it directly
                search[e] = want and not (at_end and not (0.0 < th_lo < 1.0))
                if want:
                    searched = True
                elif sign[e] > 0 and lo < mins[e]:
                    mins[e] = lo
        h_prev = h
        if searched:
            n_searched += 1

        switch = False
        if searched:
            if not prepared:
                dense_prepare(rhs, y, h, n, A, n_stages, n_dense, P, n_poly, K, Q, tmp, p)
            theta0 = 0.0
            for e in range(N_EVENTS):
                g_ev[e] = g[e]
            while True:
                ev, theta = next_event(events, active, direction, track_min, sign, search, th_min, theta0, g_ev, g1,
                                       gr1, y, h, t, Q, n, n_poly, p, sw, hybrid, tmp, slope, G[G_LO], G[G_HI],
                                       G[G_TMP], G[G_RTMP], mins)
                if ev < 0:
                    break
                if theta >= 1.0:
                    for i in range(n):
                        y_ev[i] = y_new[i]
                else:
                    dense_eval(theta, y, h, Q, n, n_poly, y_ev)
                events(y_ev, slope, p, sw, hybrid, g_ev, G[G_RTMP])
                t_ev = t + theta * h
                act = action[ev]
                stop = False
                if act == ACT_FALL:
                    if g_ev[EV_FALL] < mins[EV_FALL]:
                        mins[EV_FALL] = g_ev[EV_FALL]
                    if rolling_phase:
                        res_i[RI_OUTCOME] = rules.fall_outcome(y_ev[0], y_ev[1], y_ev[3], 0.0, 0.0, p)
                    else:
                        res_i[RI_OUTCOME] = rules.fall_outcome(y_ev[0], y_ev[1], y_ev[3], y_ev[I_U1], y_ev[I_U3], p)
                    end = END_FALL
                    stop = True
                elif act == ACT_SLIP:
                    end = END_SWITCH
                    stop = True
                elif act == ACT_RETURN:
                    dt_return = try_return(y_ev, p, sw, t_max - t_ev, y_ret)
                    if dt_return >= 0.0:
                        end = END_SWITCH
                        stop = True
                elif act == ACT_OMEGA1:
                    if rules.transversal_omega1_zero(y_ev[0], y_ev[1], y_ev[2], y_ev[3], p, rtol):
                        n_cross += 1
                        if n_cross == 1:
                            t1 = t_ev
                        else:
                            res_f[RF_HALF_PERIOD] = t_ev - t1
                            end = END_PERIODIC
                            stop = True
                if stop:
                    for i in range(n):
                        y[i] = y_ev[i]
                    t = t_ev
                    switch = True
                    break
                sign[ev] = -sign[ev]
                update_signs(g_ev, sign, ev)
                for e in range(N_EVENTS):
                    search[e] = search[e] and theta < 1.0
                theta0 = theta
        else:
            update_signs(g1, sign, -1)
        if switch:
            break
        # the step is taken in full
        t = t_max if last else t + h
        for i in range(n):
            y[i] = y_new[i]
            f[i] = f_new[i]
        for e in range(N_EVENTS):
            g[e] = g1[e]
            gr[e] = gr1[e]
        if sign[EV_FALL] > 0 and g1[EV_FALL] < mins[EV_FALL]:
            mins[EV_FALL] = g1[EV_FALL]
        h = h_next
        after_reject = False
        if not rolling_phase:  # the return rule is checked at every slipping step end too
            dt_return = try_return(y, p, sw, t_max - t, y_ret)
            if dt_return >= 0.0:
                end = END_SWITCH
                break
    res_f[RF_T_END] = t
    res_i[RI_N_STEPS] = n_steps
    res_i[RI_N_SEARCHED] = n_searched
    return end, dt_return


@kernel(inline=True)
def trajectory(hybrid, conservative, x0, p, t_max, rtol, atol, A, E, P, n_stages, err_mode, error_order, max_steps,
               max_switches, sw, W, K, Q, G, sign, search, active_roll, active_slip, res_f, res_i):
    """One trajectory from the rolling initial state x0 in the scene (hybrid, conservative)."""
    y = W[W_Y]
    for i in range(4):
        y[i] = x0[i]
    y[4] = 0.0
    system.rolling_active(hybrid, conservative, active_roll)
    system.slipping_active(hybrid, conservative, active_slip)
    atol_roll = W[W_ATOL_ROLL]
    atol_slip = W[W_ATOL_SLIP]
    system.rolling_atol(atol, sw, atol_roll)
    system.slipping_atol(atol, sw, atol_slip)
    mins = G[G_MIN]
    for e in range(N_EVENTS):
        mins[e] = np.inf
    res_f[RF_T_END] = 0.0
    res_f[RF_HALF_PERIOD] = np.nan
    res_i[RI_OUTCOME] = ON_RIM_AT_T_MAX
    res_i[RI_STATUS] = OK
    res_i[RI_N_STEPS] = 0
    res_i[RI_N_SEARCHED] = 0
    res_i[RI_N_SLIP_STEPS] = 0
    E0 = system.rolling_energy(y, p)
    rolling_phase = True
    first = True
    switches = 0
    slip_phases = 0
    slip_time = 0.0
    t_slip0 = 0.0
    while True:
        # ---------------- phase-start checks (solver.engine.rules) ----------------
        n = N_ROLLING if rolling_phase else N_SLIPPING
        finite = True
        for i in range(n):
            if not np.isfinite(y[i]):
                finite = False
        if rolling_phase:
            f2 = rolling.normal_force(y[0], y[1], y[3], p)
            margin = rolling.friction_margin(y[0], y[1], y[2], y[3], p) if hybrid else 1.0
            steady = first and rules.on_steady_motion(y[0], y[1], y[2], y[3], p)
        else:
            f2 = slipping.slipping_normal_force(y[0], y[1], y[3], y[I_U1], y[I_U3], p)
            margin = 1.0
            steady = False
        if not (finite and np.isfinite(f2) and np.isfinite(margin)):
            res_i[RI_STATUS] = NON_FINITE
            break
        if f2 < mins[EV_FALL]:
            mins[EV_FALL] = f2
        start = rules.phase_start_action(rolling_phase, hybrid, first, f2, margin, steady)
        first = False
        if start == rules.FALL:
            if rolling_phase:
                res_i[RI_OUTCOME] = rules.fall_outcome(y[0], y[1], y[3], 0.0, 0.0, p)
            else:
                res_i[RI_OUTCOME] = rules.fall_outcome(y[0], y[1], y[3], y[I_U1], y[I_U3], p)
            break
        if start == rules.STEADY:
            res_i[RI_OUTCOME] = STEADY_MOTION
            break
        if start == rules.RUN:
            if res_f[RF_T_END] >= t_max:
                break
            # ---------------- one phase to its terminal event ----------------
            if rolling_phase:
                end, dt_return = run_phase(system.rolling_rhs, system.rolling_events, True, hybrid, bool(conservative),
                                           system.ROLLING_DIRECTION, system.ROLLING_TRACK_MIN, system.ROLLING_ACTION,
                                           active_roll, N_ROLLING, p, sw, t_max, rtol, atol_roll, A, E, P, n_stages,
                                           err_mode, error_order, max_steps, W, K, Q, G, sign, search, res_f, res_i)
            elif hybrid:  # only hybrid scenes slip: numba drops this branch from the rolling-only kernels
                steps_before = res_i[RI_N_STEPS]
                end, dt_return = run_phase(system.slipping_rhs, system.slipping_events, False, True, bool(conservative),
                                           system.SLIPPING_DIRECTION, system.SLIPPING_TRACK_MIN,
                                           system.SLIPPING_ACTION, active_slip, N_SLIPPING, p, sw, t_max, rtol, atol_slip,
                                           A, E, P, n_stages, err_mode, error_order, max_steps, W, K, Q, G, sign,
                                           search, res_f, res_i)
                res_i[RI_N_SLIP_STEPS] += res_i[RI_N_STEPS] - steps_before
            else:
                break  # unreachable: a rolling-only trajectory never leaves rolling
            if end == END_PERIODIC:
                res_i[RI_OUTCOME] = PERIODIC_ROLLING
                break
            if end != END_SWITCH:
                break
        # ---------------- the switch: start == SLIP, or a phase ended at END_SWITCH ----------------
        switches += 1
        if switches > max_switches:
            res_i[RI_STATUS] = TOO_MANY_SWITCHES
            break
        if rolling_phase:
            enter_slipping(y, p, sw)
            rolling_phase = False
            slip_phases += 1
            t_slip0 = res_f[RF_T_END]
        else:
            y_ret = W[W_Y_RET]
            for i in range(N_ROLLING):
                y[i] = y_ret[i]
            res_f[RF_T_END] += dt_return
            slip_time += res_f[RF_T_END] - t_slip0
            rolling_phase = True

    # ---------------- record ----------------
    if res_i[RI_STATUS] == MAX_STEPS and 2 * res_i[RI_N_SLIP_STEPS] >= res_i[RI_N_STEPS]:
        res_i[RI_STATUS] = STIFF_SLIP  # the budget went on stiff slip phases (docs/outcome-engine.md)
    t = res_f[RF_T_END]
    if rolling_phase:
        E1 = system.rolling_energy(y, p)
        n = N_ROLLING
    else:
        slip_time += t - t_slip0
        E1 = system.slipping_energy(y, p)
        n = N_SLIPPING
    scale = max(abs(E0), p[P_M] * p[P_G] * p[P_RHO])
    res_f[RF_F2_MIN] = mins[EV_FALL]
    res_f[RF_REVOLUTIONS] = y[n - 1] / (2.0 * np.pi)
    res_f[RF_SLIP_TIME] = slip_time
    res_f[RF_ENERGY_DRIFT] = abs(E1 - E0) / scale
    res_f[RF_BETA] = y[0]
    res_f[RF_OMEGA1] = y[1]
    res_f[RF_OMEGA2] = y[2]
    res_f[RF_OMEGA3] = y[3]
    res_i[RI_SLIP_PHASES] = slip_phases


@kernel(inline=True)
def run_scene(hybrid, conservative, states, p, t_max, rtol, atol, A, E, P, n_stages, err_mode, error_order,
              max_steps, max_switches, sw, res_f, res_i):
    """Simulate every row of ``states`` (m, 4) in the scene (hybrid, conservative); results into
    the rows of res_f, res_i. Inlined into the four scene kernels with literal flags."""
    W = np.zeros((N_W, N_MAX))
    K = np.zeros((A.shape[0], N_MAX))
    Q = np.zeros((N_MAX, P.shape[1]))
    G = np.zeros((N_G, N_EVENTS))
    sign = np.zeros(N_EVENTS, dtype=np.int64)
    search = np.zeros(N_EVENTS, dtype=np.bool_)
    act_r = np.ones(N_EVENTS, dtype=np.bool_)
    act_s = np.ones(N_EVENTS, dtype=np.bool_)
    for k in range(states.shape[0]):
        trajectory(hybrid, conservative, states[k], p, t_max, rtol, atol, A, E, P, n_stages, err_mode, error_order,
                   max_steps, max_switches, sw, W, K, Q, G, sign, search, act_r, act_s, res_f[k], res_i[k])


@kernel
def scene_rolling_conservative(states, p, t_max, rtol, atol, A, E, P, n_stages, err_mode, error_order, max_steps,
                              max_switches, sw, res_f, res_i):
    """Scene mu = inf, k_r = k_d = 0: every row of ``states`` (see :func:`run_scene`)."""
    run_scene(False, True, states, p, t_max, rtol, atol, A, E, P, n_stages, err_mode, error_order, max_steps,
              max_switches, sw, res_f, res_i)


@kernel
def scene_rolling_dissipative(states, p, t_max, rtol, atol, A, E, P, n_stages, err_mode, error_order, max_steps,
                             max_switches, sw, res_f, res_i):
    """Scene mu = inf, k_r or k_d > 0: every row of ``states`` (see :func:`run_scene`)."""
    run_scene(False, False, states, p, t_max, rtol, atol, A, E, P, n_stages, err_mode, error_order, max_steps,
              max_switches, sw, res_f, res_i)


@kernel
def scene_hybrid_conservative(states, p, t_max, rtol, atol, A, E, P, n_stages, err_mode, error_order, max_steps,
                             max_switches, sw, res_f, res_i):
    """Scene finite mu, k_r = k_d = 0: every row of ``states`` (see :func:`run_scene`)."""
    run_scene(True, True, states, p, t_max, rtol, atol, A, E, P, n_stages, err_mode, error_order, max_steps,
              max_switches, sw, res_f, res_i)


@kernel
def scene_hybrid_dissipative(states, p, t_max, rtol, atol, A, E, P, n_stages, err_mode, error_order, max_steps,
                            max_switches, sw, res_f, res_i):
    """Scene finite mu, k_r or k_d > 0: every row of ``states`` (see :func:`run_scene`)."""
    run_scene(True, False, states, p, t_max, rtol, atol, A, E, P, n_stages, err_mode, error_order, max_steps,
              max_switches, sw, res_f, res_i)


SCENE_KERNELS = {kernel.py_func.__name__: kernel for kernel in (
    scene_rolling_conservative, scene_rolling_dissipative, scene_hybrid_conservative, scene_hybrid_dissipative)}
"""The kernel of each scene by name (``SCENE_KERNELS[scene.kernel]``, ``solver.engine.scenes``): (states, p,
t_max, rtol, atol, A, E, P, n_stages, err_mode, error_order, max_steps, max_switches, sw, res_f, res_i)."""