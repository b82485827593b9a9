"""Per-trajectory scene kernels and the chunk driver of ``solver.simulate``.

A scene (docs/outcome-engine.md) is fixed by two flags, ``hybrid`` (finite mu:
rolling/slipping switching of Sect. 5.2.2) and ``conservative`` (k_r = k_d = 0: periodic
detection, Prop. 4). Two kernels serve the four named scenes: :func:`scene_rolling` (mu = inf) and
:func:`scene_hybrid` (finite mu), each running a chunk of initial states through the inlined bodies
:func:`run_scene` and :func:`trajectory`, so a rolling-only kernel holds no slipping code at all
and a process compiles only the kernels it runs. The step loop of a phase, :func:`run_phase`, is
the expensive part of the first compile; a hybrid kernel has one step loop for both phases
(``system.hybrid_rhs``: the phase told by the model), and whether the scene is conservative is a
run-time setting (``Limits.periodic``: one sign test of omega1 per step). A slipping phase takes
Rodas4 steps while it is stiff (``solver.engine.rosenbrock``, :func:`stiff_attempt`,
:func:`next_slip_mode`) and the method's explicit steps otherwise.

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

What travels between these functions travels as records (``typing.NamedTuple``, which numba
passes as structs): the method (``tableaus.Method``), the run's :class:`Limits`, the work arrays
(:class:`Work`), each phase's event table and tolerances (``system.Phase``), and inside the step
loop the step's arrays (``stepper.Arrays``) and error control (``stepper.Control``) and the
locator's records (``events.Dense``, ``events.Scratch``, ``events.Tracking``).

Every failure is recorded in ``status``; nothing raises. A step budget spent mostly in slip
phases is ``stiff_slip`` rather than ``max_steps`` (``RI_N_SLIP_STEPS`` counts those steps). Results go to one row of
``float_results``
(float64, ``RF_*`` columns) and ``int_results`` (int64, ``RI_*``).
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np
from numba import types
from numba.extending import overload

from rimroll.solver import _jit
from rimroll.solver._compile import engine_kernel
from rimroll.solver.engine import rosenbrock, rules, system
from rimroll.solver.engine.events import (
    Dense,
    Scratch,
    Tracking,
    fires,
    hermite_at,
    initial_signs,
    next_event,
    trough_possible,
    update_signs,
    value_at,
)
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
from rimroll.solver.engine.outputs import FLOAT_COLUMNS, INT_COLUMNS, column
from rimroll.solver.engine.stepper import (
    ACCEPTED,
    BUDGET_SPENT,
    UNDERFLOW,
    Arrays,
    Control,
    attempt,
    dense_eval,
    dense_prepare,
    initial_step,
)
from rimroll.solver.engine.system import (
    ACT_FALL,
    ACT_OMEGA1,
    ACT_RETURN,
    ACT_SLIP,
    EV_FALL,
    EV_OMEGA1,
    I_U1,
    I_U3,
    N_EVENTS,
    N_MAX,
    N_ROLLING,
    N_SLIPPING,
)
from rimroll.solver.physics import rolling, slipping
from rimroll.solver.physics.params import P_G, P_M, P_RHO
from rimroll.solver.physics.switching import SW_U_STOP, enter_slipping, try_return

# Result columns (solver.engine.outputs): float64 outputs in float_results, integer ones in int_results.
RF_T_END, RF_F2_MIN, RF_HALF_PERIOD = column("t_end"), column("f2_min"), column("half_period")
RF_REVOLUTIONS, RF_SLIP_TIME, RF_ENERGY_DRIFT = column("revolutions"), column("slip_time"), column("energy_drift")
RF_BETA, RF_OMEGA1, RF_OMEGA2, RF_OMEGA3 = (column(f"{x}_end") for x in ("beta", "omega1", "omega2", "omega3"))
RF_U1, RF_U3 = column("u1_end"), column("u3_end")
N_RF = len(FLOAT_COLUMNS)
RI_OUTCOME, RI_SLIP_PHASES, RI_N_STEPS = column("outcome"), column("slip_phases"), column("n_steps")
RI_STATUS, RI_N_SEARCHED, RI_N_SLIP_STEPS = column("status"), column("n_searched"), column("n_slip_steps")
N_RI = len(INT_COLUMNS)

# How a phase ends (run_phase); END_NONE: not yet.
END_NONE = -1
END_T_MAX = 0
END_FALL = 1
END_PERIODIC = 2
END_SWITCH = 3
END_FAILED = 4

# Rows of the work arrays: W (N_W, N_MAX) state vectors, G (N_G, N_EVENTS) event values.
W_Y, W_Y_NEW, W_F, W_TMP, W_Y_EV, W_SLOPE, W_Y_RET, W_F_NEW, W_ATOL_ROLL, W_ATOL_SLIP = range(10)
N_W = 10
G_G, G_GR, G_G1, G_GR1, G_EV, G_LO, G_HI, G_TMP, G_RTMP, G_MIN, G_TH, G_THIRD, G_CROSS = range(13)
N_G = 13  # G_CROSS: [omega1 crossings counted in this rolling phase, time of the first one [s], -]


class Work(NamedTuple):
    """The work arrays of one trajectory (reused by the next): state vectors ``W`` (N_W, N_MAX),
    stages ``K`` (n_dense, N_MAX), dense-output coefficients ``Q`` (N_MAX, n_poly), event values
    ``G`` (N_G, N_EVENTS), each event's ``sign`` (int64) and gate flag ``search`` (bool), the
    events each phase of the scene has, ``active`` (2, N_EVENTS) bool (rolling, slipping), and the
    arrays of the Rosenbrock steps of slip phases (``solver.engine.rosenbrock``): stages ``R``
    (rosenbrock.N_ROWS, N_MAX), the Jacobian ``J`` and its LU factors ``LU`` (N_MAX, N_MAX), the
    pivots ``piv`` (N_MAX, int64)."""

    W: np.ndarray
    K: np.ndarray
    Q: np.ndarray
    G: np.ndarray
    sign: np.ndarray
    search: np.ndarray
    active: np.ndarray
    R: np.ndarray
    J: np.ndarray
    LU: np.ndarray
    piv: np.ndarray


class Limits(NamedTuple):
    """The settings of a run that every trajectory shares: t_max [s], rtol [1], atol [units of each
    component], the step budget and the budget of rolling/slipping switches per trajectory,
    whether periodic rolling is detected (``periodic``: the scene is conservative, Prop. 4), and
    whether slip phases take Rosenbrock steps while stiff (``stiff_slips``; else the method's
    explicit steps throughout)."""

    t_max: float
    rtol: float
    atol: float
    max_steps: int
    max_switches: int
    periodic: bool
    stiff_slips: bool = True


@engine_kernel(inline=True)
def scratch_of(work):
    """The locator's scratch arrays inside the work arrays."""
    W = work.W
    G = work.G
    return Scratch(W[W_TMP], W[W_SLOPE], G[G_TMP], G[G_RTMP], G[G_LO], G[G_HI])


@engine_kernel(inline=True, takes_functions=True)
def begin_phase(rhs, events, event_tol, phase, model, work, t, rtol):
    """Slopes, event values and signs at the start of a phase from W[W_Y] at time t [s]; the omega1
    crossing count starts at 1 if the phase starts on a transversal zero of omega1 (conservative
    rolling). False if the slopes are not finite."""
    W = work.W
    G = work.G
    K = work.K
    y = W[W_Y]
    f = W[W_F]
    rhs(y, model, K, np.int64(0))  # int64, not Literal[int]: one compiled callee
    for i in range(phase.n):
        f[i] = K[0, i]
        if not np.isfinite(f[i]):
            return False
    events(y, f, model, event_tol, G[G_G], G[G_GR])
    initial_signs(G[G_G], phase.direction, work.sign)
    for e in range(N_EVENTS):
        G[G_THIRD, e] = np.nan
    G[G_CROSS, 0] = 0.0
    G[G_CROSS, 1] = 0.0
    if phase.active[EV_OMEGA1] and y[1] == 0.0 and rules.transversal_omega1_zero(
            y[0], y[1], y[2], y[3], model.p, rtol, system.rolling_load(model, y)):
        G[G_CROSS, 0] = 1.0
        G[G_CROSS, 1] = t
    return True


@engine_kernel(inline=True, takes_functions=True)
def gate(rhs, events, event_tol, phase, model, method, rtol, h, h_prev, work, prepared):
    """Does the accepted step of length h [s] need its dense output searched for events? (the
    grazing gate of ``solver.engine.events``). ``prepared``: the step's dense output is in work.Q
    already (a Rosenbrock step). Returns (searched, dense output prepared); sets ``work.search``,
    the running minima and the gate's memory of the step (G_TH, G_THIRD)."""
    W = work.W
    G = work.G
    g = G[G_G]
    gr = G[G_GR]
    g1 = G[G_G1]
    gr1 = G[G_GR1]
    searched = False
    for e in range(N_EVENTS):
        work.search[e] = False
        if not phase.active[e]:
            continue
        at_end = fires(e, work.sign, g1[e], phase.active, phase.direction)
        if at_end or not np.isfinite(gr1[e]):
            searched = True
        if phase.track_min[e]:
            mid_err = 0.0
            if not np.isfinite(G[G_THIRD, e]):  # first step of the phase: measure the remainder
                if not prepared:
                    dense_prepare(rhs, method, W[W_Y], h, phase.n, work.K, work.Q, W[W_TMP], model)
                    prepared = True
                dense = Dense(W[W_Y], h, 0.0, work.Q, phase.n)
                g_mid = value_at(events, e, 0.5, dense, model, event_tol, scratch_of(work))
                mid_err = abs(g_mid - hermite_at(g[e], gr[e], g1[e], gr1[e], h, 0.5))
            want, lo, th_lo, third = trough_possible(g[e], gr[e], g1[e], gr1[e], h, h_prev, G[G_THIRD, e], mid_err,
                                                     rtol)
            G[G_THIRD, e] = third
            G[G_TH, e] = th_lo
            # a crossing at the end with no interior trough of H: locate it directly
            work.search[e] = want and not (at_end and not (0.0 < th_lo < 1.0))
            if want:
                searched = True
            elif work.sign[e] > 0 and lo < G[G_MIN, e]:
                G[G_MIN, e] = lo
    return searched, prepared


@engine_kernel(takes_functions=True)
def act_on_events(events, event_tol, return_tol, phase, model, limits, work, t, h, float_results, int_results):
    """The events of an accepted step from t [s] of length h [s], in time order, each with its
    action (the phase's event table): fall, periodic orbit, slip, return to rolling or an omega1
    crossing counted. Returns (END_* of the phase, or END_NONE if the step is taken in full; the
    time of the event that ends it [s]; the time of a return to rolling [s] or -1)."""
    W = work.W
    G = work.G
    y = W[W_Y]
    y_ev = W[W_Y_EV]
    g_ev = G[G_EV]
    n = phase.n
    dense = Dense(y, h, t, work.Q, n)
    scratch = scratch_of(work)
    tracking = Tracking(work.sign, work.search, G[G_TH], G[G_MIN])
    dt_return = -1.0
    theta0 = 0.0
    for e in range(N_EVENTS):
        g_ev[e] = G[G_G, e]
    while True:
        ev, theta = next_event(events, phase, tracking, theta0, g_ev, G[G_G1], G[G_GR1], dense, model, event_tol,
                               scratch)
        if ev < 0:
            return END_NONE, t, dt_return
        if theta >= 1.0:
            for i in range(n):
                y_ev[i] = W[W_Y_NEW, i]
        else:
            dense_eval(theta, y, h, work.Q, n, work.Q.shape[1], y_ev)
        events(y_ev, W[W_SLOPE], model, event_tol, g_ev, G[G_RTMP])
        t_ev = t + theta * h
        act = phase.action[ev]
        if return_tol is not None and model.slipping:  # (None: rolling only, numba drops the slipping actions)
            end, dt_return = slipping_action(act, y_ev, model, return_tol, limits.t_max - t_ev, work, int_results)
        else:
            end = rolling_action(act, y_ev, model, limits.rtol, t_ev, work, float_results, int_results)
        if end != END_NONE:
            for i in range(n):
                y[i] = y_ev[i]
            return end, t_ev, dt_return
        work.sign[ev] = -work.sign[ev]
        update_signs(g_ev, work.sign, ev)
        for e in range(N_EVENTS):
            work.search[e] = work.search[e] and theta < 1.0
        theta0 = theta


@engine_kernel(inline=True)
def rolling_action(act, y_ev, model, rtol, t_ev, work, float_results, int_results):
    """The action of a rolling event at the state y_ev, time t_ev [s]: END_FALL (outcome by free
    flight), END_SWITCH (the ball starts to slip), END_PERIODIC (a second transversal omega1 zero)
    or END_NONE (a first one counted)."""
    G = work.G
    if act == ACT_FALL:
        if G[G_EV, EV_FALL] < G[G_MIN, EV_FALL]:
            G[G_MIN, EV_FALL] = G[G_EV, EV_FALL]
        int_results[RI_OUTCOME] = rules.fall_outcome(y_ev[0], y_ev[1], y_ev[3], 0.0, 0.0, model.p)
        return END_FALL
    if act == ACT_SLIP:
        return END_SWITCH
    if act == ACT_OMEGA1 and rules.transversal_omega1_zero(y_ev[0], y_ev[1], y_ev[2], y_ev[3], model.p, rtol,
                                                           system.rolling_load(model, y_ev)):
        G[G_CROSS, 0] += 1.0
        if G[G_CROSS, 0] == 1.0:
            G[G_CROSS, 1] = t_ev
        else:
            float_results[RF_HALF_PERIOD] = t_ev - G[G_CROSS, 1]
            return END_PERIODIC
    return END_NONE


@engine_kernel(inline=True)
def slipping_action(act, y_ev, model, switch_tol, t_left, work, int_results):
    """The action of a slipping event at the state y_ev, t_left [s] before t_max: END_FALL
    (outcome by free flight), END_SWITCH (the return rule lets the ball roll again: its rolling
    state in W[W_Y_RET]) or END_NONE. Returns (end, the time of the return [s] or -1)."""
    G = work.G
    if act == ACT_FALL:
        if G[G_EV, EV_FALL] < G[G_MIN, EV_FALL]:
            G[G_MIN, EV_FALL] = G[G_EV, EV_FALL]
        int_results[RI_OUTCOME] = rules.fall_outcome(y_ev[0], y_ev[1], y_ev[3], y_ev[I_U1], y_ev[I_U3], model.p)
        return END_FALL, -1.0
    if act == ACT_RETURN:
        dt_return = try_return(y_ev, model.p, switch_tol, t_left, work.W[W_Y_RET], model.load_fn)
        if dt_return >= 0.0:
            return END_SWITCH, dt_return
        return END_NONE, dt_return
    return END_NONE, -1.0


@engine_kernel(inline=True)
def slip_end_cap(y, f, switch_tol):
    """Largest step [s] of a slipping phase whose slip speed u falls: the time for u to fall to half
    the return threshold u_stop at its present rate (so that a large implicit step cannot pass
    u = 0, where the slip direction of (42) is undefined); infinite while u grows."""
    u = np.hypot(y[system.I_U1], y[system.I_U3])
    rate = (y[system.I_U1] * f[system.I_U1] + y[system.I_U3] * f[system.I_U3]) / u
    u_stop = switch_tol[SW_U_STOP]
    if rate < 0.0 and u > u_stop:
        return (u - 0.5 * u_stop) / -rate
    return np.inf


@engine_kernel(takes_functions=True)
def stiff_attempt(rhs, return_tol, control, model, method, arrays, work, t, h, after_reject, budget):
    """A Rosenbrock step attempt of a slipping phase (``rosenbrock.attempt``) with the Jacobian of
    (42) at the step's start, the step capped by :func:`slip_end_cap`. Returns rosenbrock.attempt's
    tuple and the stiffness (``rosenbrock.stiffness`` of the slip-velocity block) [1/s]."""
    y = arrays.y
    system.slipping_jacobian(y, model, work.J, work.R, rosenbrock.ROW_JAC, work.W[W_SLOPE])
    h = min(h, slip_end_cap(y, arrays.f, return_tol))
    code, h, h_next, attempts, last = rosenbrock.attempt(rhs, system.N_SLIPPING, control, model, arrays, work,
                                                         method.n_stages, t, h, after_reject, budget)
    return code, h, h_next, attempts, last, slip_stiffness(work)


@engine_kernel(inline=True)
def slip_stiffness(work):
    """The spectral radius [1/s] of the slipping Jacobian in work.J (``rosenbrock.spectral_radius``)."""
    return rosenbrock.spectral_radius(work.J, system.N_SLIPPING - 1, work.R[rosenbrock.ROW_JAC],
                                      work.R[rosenbrock.ROW_JAC + 1])


@engine_kernel
def first_return(y, h, n, t, model, switch_tol, t_max, work):
    """The first point of a slipping step from (t [s], y) of length h [s], whose end meets the
    return rule (``switching.try_return``), where the rule is met: bisection (40 halvings of h) on
    the step's dense output (work.Q), so that the return does not wait for the end of a long
    step. Moves y and t there and returns (t, the time advanced by the return [s]); W[W_Y_RET]
    holds the rolling state."""
    W = work.W
    y_at = W[W_Y_EV]
    n_poly = work.Q.shape[1]
    lo = 0.0
    hi = 1.0
    for _ in range(40):
        mid = 0.5 * (lo + hi)
        dense_eval(mid, y, h, work.Q, n, n_poly, y_at)
        if try_return(y_at, model.p, switch_tol, t_max - t - mid * h, W[W_Y_RET], model.load_fn) >= 0.0:
            hi = mid
        else:
            lo = mid
    if hi < 1.0:
        dense_eval(hi, y, h, work.Q, n, n_poly, y_at)
        for i in range(n):
            y[i] = y_at[i]
    else:
        for i in range(n):
            y[i] = W[W_Y_NEW, i]
    t = t + hi * h
    return t, try_return(y, model.p, switch_tol, t_max - t, W[W_Y_RET], model.load_fn)


@engine_kernel
def next_slip_mode(stiff, rho, h, h_next, y, model, work, since_check):
    """Rosenbrock (True) or explicit steps next in a slipping phase, and the explicit steps since the
    last look at the stiffness. After a Rosenbrock step: explicit once the next step h_next [s] times
    the stiffness rho [1/s] falls below ``rosenbrock.STIFF_SWITCH``. After explicit steps: every
    ``rosenbrock.CHECK_EVERY`` steps the Jacobian at y and its spectral radius; Rosenbrock again if
    the step just taken, h [s], was near the explicit stability limit (h rho >
    ``rosenbrock.EXPLICIT_LIMIT``)."""
    if stiff:
        return h_next * rho >= rosenbrock.STIFF_SWITCH, 0
    if since_check + 1 < rosenbrock.CHECK_EVERY:
        return False, since_check + 1
    system.slipping_jacobian(y, model, work.J, work.R, rosenbrock.ROW_JAC, work.W[W_SLOPE])
    return h * slip_stiffness(work) > rosenbrock.EXPLICIT_LIMIT, 0


@engine_kernel(takes_functions=True)
def run_phase(rhs, events, event_tol, return_tol, phase, model, method, limits, work, float_results, int_results):
    """Run one phase from the state W[W_Y] at time float_results[RF_T_END] to its terminal event.

    rhs, events: the phase's right-hand side and event function (``solver.engine.system``); event_tol:
    what ``events`` takes besides the state (the switching tolerances in scenes that slip, else
    None); return_tol: the switching tolerances of the return rule in a slipping phase, None in a rolling
    one; phase: its ``system.Phase`` (event table, tolerances). Returns (how the phase ends: END_*,
    the time of a return to rolling [s] or -1). On END_SWITCH of a slipping phase W[W_Y_RET]
    holds the rolling state of the return; on END_FALL int_results[RI_OUTCOME] is set; on END_PERIODIC
    float_results[RF_HALF_PERIOD]; on END_FAILED int_results[RI_STATUS].
    """
    W = work.W
    G = work.G
    K = work.K
    n = phase.n
    y = W[W_Y]
    y_new = W[W_Y_NEW]
    f = W[W_F]
    f_new = W[W_F_NEW]
    t = float_results[RF_T_END]
    t_max = limits.t_max
    rtol = limits.rtol
    n_steps = int_results[RI_N_STEPS]
    n_searched = int_results[RI_N_SEARCHED]
    if not begin_phase(rhs, events, event_tol, phase, model, work, t, rtol):
        int_results[RI_STATUS] = NON_FINITE
        return END_FAILED, -1.0
    control = Control(n, n - 1, rtol, phase.atol, t_max)
    arrays = Arrays(y, f, K, y_new, W[W_TMP])
    h = initial_step(rhs, y, f, n, n - 1, method.error_order, rtol, phase.atol, t_max - t, W[W_TMP], K, model)
    h_prev = h
    after_reject = False
    end = END_T_MAX
    dt_return = -1.0
    stiff_mode = limits.stiff_slips  # a slip starts at a small slip speed: stiff
    since_check = np.int64(0)  # int64, not Literal[int]: one compiled callee
    while t < t_max:
        stiff = False
        if return_tol is not None:
            if model.slipping:
                stiff = stiff_mode
        rho = 0.0
        if stiff:
            code, h, h_next, attempts, last, rho = stiff_attempt(rhs, return_tol, control, model, method, arrays, work,
                                                                 t, h, after_reject, limits.max_steps - n_steps)
        else:
            code, h, h_next, attempts, last = attempt(rhs, method, control, model, arrays, t, h, after_reject,
                                                      limits.max_steps - n_steps)
        n_steps += attempts
        if code != ACCEPTED:
            int_results[RI_STATUS] = MAX_STEPS if code == BUDGET_SPENT else (
                STEP_SIZE_UNDERFLOW if code == UNDERFLOW else NON_FINITE)
            end = END_FAILED
            break
        for i in range(n):  # the FSAL slope of y_new (the slope of y is in K[0])
            f_new[i] = K[method.n_stages, i]
        events(y_new, f_new, model, event_tol, G[G_G1], G[G_GR1])
        searched, prepared = gate(rhs, events, event_tol, phase, model, method, rtol, h, h_prev, work, stiff)
        h_prev = h
        if searched:
            n_searched += 1
            if not prepared:
                dense_prepare(rhs, method, y, h, n, K, work.Q, W[W_TMP], model)
                prepared = True
            end, t, dt_return = act_on_events(events, event_tol, return_tol, phase, model, limits, work, t, h,
                                              float_results, int_results)
            if end != END_NONE:
                break
            end = END_T_MAX
        else:
            update_signs(G[G_G1], work.sign, np.int64(-1))
        if return_tol is not None and model.slipping:  # the return rule (switching.try_return) met within the step?
            if try_return(y_new, model.p, return_tol, t_max - t - h, W[W_Y_RET], model.load_fn) >= 0.0:
                if not prepared:
                    dense_prepare(rhs, method, y, h, n, K, work.Q, W[W_TMP], model)
                t, dt_return = first_return(y, h, n, t, model, return_tol, t_max, work)
                end = END_SWITCH
                break
        # the step is taken in full
        t = t_max if last else t + h
        for i in range(n):
            y[i] = y_new[i]
            f[i] = f_new[i]
        for e in range(N_EVENTS):
            G[G_G, e] = G[G_G1, e]
            G[G_GR, e] = G[G_GR1, e]
        if work.sign[EV_FALL] > 0 and G[G_G1, EV_FALL] < G[G_MIN, EV_FALL]:
            G[G_MIN, EV_FALL] = G[G_G1, EV_FALL]
        if return_tol is not None and model.slipping and limits.stiff_slips:
            stiff_mode, since_check = next_slip_mode(stiff, rho, h, h_next, y, model, work, since_check)
        h = h_next
        after_reject = False
    float_results[RF_T_END] = t
    int_results[RI_N_STEPS] = n_steps
    int_results[RI_N_SEARCHED] = n_searched
    return end, dt_return


def scene_phase(switch_tol, phase, model, method, limits, work, float_results, int_results):
    """One phase of a trajectory (:func:`run_phase`) with the systems of the scene: in a rolling-only
    scene (switch_tol None) the rolling system and no return rule; in a scene that slips one step loop for
    both phases (``system.hybrid_rhs``: ``model.slipping`` says which). Compiled code takes the
    choice from the type of ``switch_tol`` (:func:`_scene_phase`), so each kernel holds one step loop."""
    if switch_tol is None:
        return run_phase(system.rolling_rhs, system.rolling_events, None, None, phase, model, method, limits, work,
                         float_results, int_results)
    return run_phase(system.hybrid_rhs, system.hybrid_events, switch_tol, switch_tol, phase, model, method, limits,
                     work, float_results, int_results)


@overload(scene_phase, jit_options={"nogil": True, **_jit.NO_REFCOUNT})
def _scene_phase(switch_tol, phase, model, method, limits, work, float_results, int_results):
    if isinstance(switch_tol, (types.NoneType, types.Omitted)):
        def rolling_only(switch_tol, phase, model, method, limits, work, float_results, int_results):
            return run_phase(system.rolling_rhs, system.rolling_events, None, None, phase, model, method, limits,
                             work, float_results, int_results)
        return rolling_only

    def hybrid(switch_tol, phase, model, method, limits, work, float_results, int_results):
        return run_phase(system.hybrid_rhs, system.hybrid_events, switch_tol, switch_tol, phase, model, method, limits,
                         work, float_results, int_results)
    return hybrid


@engine_kernel(inline=True)
def begin_trajectory(x0, p, work, float_results, int_results):
    """Reset the work arrays and the result row for a trajectory from the rolling state x0;
    returns its energy (60) [J]."""
    y = work.W[W_Y]
    for i in range(4):
        y[i] = x0[i]
    y[4] = 0.0
    for e in range(N_EVENTS):
        work.G[G_MIN, e] = np.inf
    float_results[RF_T_END] = 0.0
    float_results[RF_HALF_PERIOD] = np.nan
    int_results[RI_OUTCOME] = ON_RIM_AT_T_MAX
    int_results[RI_STATUS] = OK
    int_results[RI_N_STEPS] = 0
    int_results[RI_N_SEARCHED] = 0
    int_results[RI_N_SLIP_STEPS] = 0
    return system.rolling_energy(y, p)


@engine_kernel(inline=True)
def start_action(switch_tol, rolling_phase, first, y, model, mins):
    """The rules' action at the start of a phase (``rules.phase_start_action``), or -1 when the
    state or its normal force is not finite; lowers the running minimum of F2."""
    n = N_ROLLING if rolling_phase else N_SLIPPING
    finite = True
    for i in range(n):
        if not np.isfinite(y[i]):
            finite = False
    p = model.p
    if rolling_phase:
        load = system.rolling_load(model, y)
        f2 = rolling.normal_force(y[0], y[1], y[3], p, load)
        margin = rolling.friction_margin(y[0], y[1], y[2], y[3], p, load) if switch_tol is not None else 1.0
        steady = first and rules.on_steady_motion(y[0], y[1], y[2], y[3], p, load)
    else:
        f2 = slipping.slipping_normal_force(y[0], y[1], y[3], y[I_U1], y[I_U3], p, system.slipping_load(model, y))
        margin = 1.0
        steady = False
    if not (finite and np.isfinite(f2) and np.isfinite(margin)):
        return -1
    if f2 < mins[EV_FALL]:
        mins[EV_FALL] = f2
    return rules.phase_start_action(rolling_phase, switch_tol is not None, first, f2, margin, steady)


@engine_kernel(inline=True)
def record(rolling_phase, y, p, E0, slip_time, t_slip0, slip_phases, work, float_results, int_results):
    """The result row at the end of a trajectory: status stiff_slip for a budget spent mostly in
    slip phases, F2's minimum, revolutions, time slipping, energy drift and the final state."""
    if int_results[RI_STATUS] == MAX_STEPS and 2 * int_results[RI_N_SLIP_STEPS] >= int_results[RI_N_STEPS]:
        int_results[RI_STATUS] = STIFF_SLIP  # the budget went on stiff slip phases (docs/outcome-engine.md)
    t = float_results[RF_T_END]
    if rolling_phase:
        E1 = system.rolling_energy(y, p)
        n = N_ROLLING
    else:
        slip_time += t - t_slip0
        E1 = system.slipping_energy(y, p)
        n = N_SLIPPING
    scale = max(abs(E0), p[P_M] * p[P_G] * p[P_RHO])
    float_results[RF_F2_MIN] = work.G[G_MIN, EV_FALL]
    float_results[RF_REVOLUTIONS] = y[n - 1] / (2.0 * np.pi)
    float_results[RF_SLIP_TIME] = slip_time
    float_results[RF_ENERGY_DRIFT] = abs(E1 - E0) / scale
    float_results[RF_BETA] = y[0]
    float_results[RF_OMEGA1] = y[1]
    float_results[RF_OMEGA2] = y[2]
    float_results[RF_OMEGA3] = y[3]
    float_results[RF_U1] = 0.0 if rolling_phase else y[I_U1]
    float_results[RF_U3] = 0.0 if rolling_phase else y[I_U3]
    int_results[RI_SLIP_PHASES] = slip_phases


@engine_kernel(inline=True)
def trajectory(switch_tol, x0, model, method, limits, work, float_results, int_results):
    """One trajectory from the rolling initial state x0 in the scene: switch_tol, the switching tolerances
    of a scene that slips (None: rolling only; numba then compiles no slipping code); periodic
    rolling is detected where ``limits.periodic``."""
    W = work.W
    y = W[W_Y]
    roll, slip = system.phases(switch_tol, limits.periodic, limits.atol, work.active, W[W_ATOL_ROLL], W[W_ATOL_SLIP])
    p = model.p
    E0 = begin_trajectory(x0, p, work, float_results, int_results)
    rolling_phase = True
    first = True
    switches = 0
    slip_phases = 0
    slip_time = 0.0
    t_slip0 = 0.0
    dt_return = -1.0
    while True:
        start = start_action(switch_tol, rolling_phase, first, y, model, work.G[G_MIN])
        first = False
        if start < 0:
            int_results[RI_STATUS] = NON_FINITE
            break
        if start == rules.FALL:
            if rolling_phase:
                int_results[RI_OUTCOME] = rules.fall_outcome(y[0], y[1], y[3], 0.0, 0.0, p)
            else:
                int_results[RI_OUTCOME] = rules.fall_outcome(y[0], y[1], y[3], y[I_U1], y[I_U3], p)
            break
        if start == rules.STEADY:
            int_results[RI_OUTCOME] = STEADY_MOTION
            break
        if start == rules.RUN:
            if float_results[RF_T_END] >= limits.t_max:
                break
            # ---------------- one phase to its terminal event ----------------
            steps_before = int_results[RI_N_STEPS]
            phase = roll if rolling_phase else slip
            end, dt_return = scene_phase(switch_tol, phase, system.Model(p, model.load_fn, not rolling_phase), method,
                                         limits, work, float_results, int_results)
            if not rolling_phase:
                int_results[RI_N_SLIP_STEPS] += int_results[RI_N_STEPS] - steps_before
            if end == END_PERIODIC:
                int_results[RI_OUTCOME] = PERIODIC_ROLLING
                break
            if end != END_SWITCH:
                break
        # ---------------- the switch: start == SLIP, or a phase ended at END_SWITCH ----------------
        if switch_tol is None:
            break  # unreachable: a rolling-only trajectory never switches
        switches += 1
        if switches > limits.max_switches:
            int_results[RI_STATUS] = TOO_MANY_SWITCHES
            break
        if rolling_phase:
            enter_slipping(y, p, switch_tol, model.load_fn)
            rolling_phase = False
            slip_phases += 1
            t_slip0 = float_results[RF_T_END]
        else:
            for i in range(N_ROLLING):
                y[i] = W[W_Y_RET, i]
            float_results[RF_T_END] += dt_return
            slip_time += float_results[RF_T_END] - t_slip0
            rolling_phase = True
    record(rolling_phase, y, p, E0, slip_time, t_slip0, slip_phases, work, float_results, int_results)


def new_work(method) -> Work:
    """Zeroed work arrays for trajectories integrated with ``method`` (a ``tableaus.Method``), made in
    Python: the kernels allocate nothing (they are compiled without numba's runtime, ``solver._jit``)."""
    return Work(np.zeros((N_W, N_MAX)), np.zeros((method.A.shape[0], N_MAX)), np.zeros((N_MAX, method.P.shape[1])),
                np.zeros((N_G, N_EVENTS)), np.zeros(N_EVENTS, dtype=np.int64), np.zeros(N_EVENTS, dtype=np.bool_),
                np.ones((2, N_EVENTS), dtype=np.bool_), np.zeros((rosenbrock.N_ROWS, N_MAX)),
                np.zeros((N_MAX, N_MAX)), np.zeros((N_MAX, N_MAX)), np.zeros(N_MAX, dtype=np.int64))


@engine_kernel(inline=True)
def run_scene(switch_tol, states, model, method, limits, work, float_results, int_results):
    """Simulate every row of ``states`` (m, 4) in the scene (switch_tol: None for rolling only) with the work
    arrays ``work`` (:func:`new_work`); results into the rows of float_results, int_results. Inlined into the scene
    kernels."""
    for k in range(states.shape[0]):
        trajectory(switch_tol, states[k], model, method, limits, work, float_results[k], int_results[k])


@engine_kernel
def scene_rolling(states, p, switch_tol, method, limits, work, float_results, int_results):
    """Scenes with mu = inf (switch_tol is None): every row of ``states`` (see :func:`run_scene`)."""
    run_scene(switch_tol, states, system.Model(p, None, False), method, limits, work, float_results, int_results)


@engine_kernel
def scene_hybrid(states, p, switch_tol, method, limits, work, float_results, int_results):
    """Scenes with finite mu (rolling and slipping): every row of ``states`` (see :func:`run_scene`)."""
    run_scene(switch_tol, states, system.Model(p, None, False), method, limits, work, float_results, int_results)


SCENE_KERNELS = {kernel.py_func.__name__: kernel for kernel in (scene_rolling, scene_hybrid)}
"""The kernel of each scene by name (``SCENE_KERNELS[scene.kernel]``, ``solver.engine.scenes``):
(states, p, switch_tol, method, limits, work, float_results, int_results) with ``method`` a ``tableaus.Method``,
``limits`` a :class:`Limits` and ``work`` the arrays of :func:`new_work`."""
