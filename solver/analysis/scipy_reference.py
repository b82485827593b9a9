"""A slow but simple reference for ``solver.simulate``: scipy ``solve_ivp`` with the same rules.

Every scene: rolling only (mu = inf) and hybrid rolling/slipping (finite mu), conservative or
dissipative. Physics and switching maps are the engine's own compiled functions
(``solver.rolling``, ``solver.slipping``, ``solver.physics.switching``, ``solver.physics.flight``); what is
independent is the integration (scipy), the event location (scipy's events, ``brentq``,
bisection) and the bookkeeping of phases written out here.

One loop of phases serves every scene (:func:`integrate`) and also ``solver.analysis.phase_trace``, which
samples the dense output of the phases it records. In rolling-only scenes there is one rolling
phase (the hybrid scenes' rolling phase below, without the slip onset): F2 < 0 at t = 0 falls at once; a fall is
classified by the free flight of
``solver.physics.flight``; two transversal omega1 zeros give ``periodic_rolling`` with half_period =
t2 - t1; otherwise the ball is on the rim at t_max.

Hybrid scenes (finite mu; the rules of ``solver.physics.switching`` and ``solver.engine.kernels``). One
``solve_ivp`` call per phase (plus, rarely, a second one, below):

* a phase starts with its checks, in the engine's order: F2 < 0 (31)/(41): fall now (free flight
  with the slip velocity of a slipping ball); rolling outside the friction cone (39): slip now
  (``switching.enter_slipping``, a contact-impulse launch u = delta e(phi1)); t >= t_max: on the
  rim;
* rolling phase events: fall (F2 (31) down), slip onset (friction margin (39) down, then
  ``enter_slipping`` at the event state) and, in conservative scenes, omega1 zero crossings:
  two within ONE rolling phase give ``periodic_rolling`` (the count restarts at every rolling
  phase, so no slip lies between them). scipy's event stops the run at its second zero of
  omega1, a touching (non-transversal) zero included; when that stop leaves fewer than two
  transversal zeros, the phase is integrated again without stopping at omega1 zeros;
* slipping phase events: fall (F2 (41) down: free flight with the slip velocities) and the
  return, an event function that is +1 while ``switching.try_return`` refuses the return and
  -1 once it allows it; the first allowed time on the dense output (also at the phase start)
  is found by sampling and bisection, and ``try_return`` then gives the rolling state after
  its extrapolated time u / (-u_dot*). The engine checks the return where |u| crosses u_stop
  downward and at its step ends, so its return time lies after the reference's first allowed
  time by at most one of its (short, slip-limited) steps.

scipy looks for sign changes only at step ends, so an F2 dip below zero inside one step is
missed (scipy issue #9228). The reference therefore locates every interior minimum of F2 with a
non-terminal event dF2/dt = 0 (upward) and checks F2 there: the first minimum with F2 < 0 is
a fall, at the zero before it (``brentq``), if it comes before the event scipy reported. The
friction margin (39) has no cheap derivative: its downward crossings are also sampled on the
dense output, GRAZE_SAMPLES points per step.

Rules that are not integration — the steady-motion test at t = 0, what counts as a transversal
omega1 zero, the free flight — are ``solver.engine.rules``, the same functions the engine calls.

Results per state: outcome, t_end, half_period, nfev (right-hand-side evaluations of every
``solve_ivp`` call), slip_phases, slip_time [s] (0 in rolling-only scenes) and energy_drift,
|E(t_end) - E(0)| / max(|E(0)|, m g rho), as ``solver.simulate`` reports it.

Used by the tests and by the work-precision study as the independent baseline.
"""

from __future__ import annotations

import dataclasses

import numpy as np
from scipy.integrate import solve_ivp
from scipy.optimize import brentq

from rimroll.solver.engine import rules, scene_code
from rimroll.solver.engine.outcomes import ON_RIM_AT_T_MAX, PERIODIC_ROLLING, STEADY_MOTION
from rimroll.solver.engine.scenes import scene_of
from rimroll.solver.physics import kinematics, rolling, slipping, switching
from rimroll.solver.physics.params import P_G, P_M, P_RHO, Params

ROLLING, SLIPPING = 0, 1
PHASE_MEANINGS = {ROLLING: "rolling", SLIPPING: "slipping"}

EVENT_KINDS = ("start", "slip_onset", "return_to_rolling", "omega1_zero", "fall", "periodic", "t_max", "steady_motion")
"""Kinds of the events :func:`integrate` records, in the order of their integer codes in a trace
file. A run that ends for another reason (``too_many_switches``, ``integration_failed``) ends
with a ``t_max`` event; its ``reason`` says why."""

GRAZE_SAMPLES = 32
RETURN_XTOL_EPS = 4.0  # bracket of the first allowed return time, in machine epsilons of t
_EPS = np.finfo(float).eps
_SAMPLE_CHUNK = 512  # steps sampled at once on the dense output


def _root(f, a, b):
    """Zero of f on [a, b] with f(a) > 0 > f(b) (brentq to ~4 eps).

    At a step end the two neighbouring dense-output pieces differ by about the local error, so a
    bracket found by sampling one piece may not bracket on re-evaluation: then the bracket end
    where f is already <= 0 (or b) is the zero within that error.
    """
    fa, fb = f(a), f(b)
    if fa > 0 > fb:
        return brentq(f, a, b, xtol=1e-15, rtol=4 * np.finfo(float).eps)
    return a if fa <= 0 else b


def _first_dip(sol, F2, t_mins, t_end):
    """First zero of F2 before the first located minimum of F2 in (t0, t_end) where F2 < 0, or None.

    ``t_mins``: the times of the interior minima of F2 (a non-terminal dF2/dt = 0 event, upward).
    F2 > 0 at the phase start and at every earlier minimum, so exactly one downward zero lies
    between the last of those and the first negative minimum.
    """
    t_lo = float(sol.t[0])
    for tm in t_mins:
        if tm >= t_end:
            break
        if F2(sol.sol(tm)) < 0.0:
            return _root(lambda t: F2(sol.sol(t)), t_lo, float(tm))
        t_lo = float(tm)
    return None


def scipy_event(value, terminal, direction):
    """A ``solve_ivp`` event function (t, y) -> value(y), with its terminal and direction attributes."""
    def event(t, y):
        return value(y)

    event.terminal = terminal
    event.direction = direction
    return event


def _omega1_zero():
    """omega1 = 0 either way; the run stops at the second zero (Prop. 4: periodic)."""
    return scipy_event(lambda y: y[1], terminal=2, direction=0)


def _transversal_zeros(t_w1, y_w1, system, rtol) -> list[float]:
    """Times of the transversal omega1 zeros (``solver.engine.rules``) among scipy's omega1 events."""
    return [float(t) for t, y in zip(t_w1, y_w1) if _starts_crossing(y, system, rtol, at_zero=False)]


def _starts_crossing(y, system, rtol, at_zero=True):
    """Whether omega1 = 0 here (``at_zero``: exactly) crosses with a transversal slope (a first crossing)."""
    if at_zero and y[1] != 0.0:
        return False
    return bool(rules.transversal_omega1_zero(y[0], y[1], y[2], y[3], system.p, rtol, system.load(y)))


def _energy_drift(E0, E1, p):
    return abs(E1 - E0) / max(abs(E0), p[P_M] * p[P_G] * p[P_RHO])


# ------------------------------------------------------------------------------ hybrid scenes


def _sampled_first(sol, t_end, value, wanted):
    """Earliest sample pair on the dense output in [t0, t_end] where the event condition turns on.

    The dense output is sampled at GRAZE_SAMPLES + 1 points per integrator step (step ends
    included). ``value(y)`` gives an event value at one state; ``wanted(g_prev, g_next)`` says
    whether the pair brackets the event. Returns (t_prev, t_next, g_prev, g_next) or None.
    """
    ts = np.asarray(sol.t)
    n = len(ts) - 1
    frac = np.linspace(0.0, 1.0, GRAZE_SAMPLES + 1)
    for lo in range(0, n, _SAMPLE_CHUNK):
        hi = min(n, lo + _SAMPLE_CHUNK)
        a = ts[lo:hi]
        b = np.minimum(ts[lo + 1:hi + 1], t_end)
        if a[0] >= t_end:
            return None
        T = a[:, None] + (b - a)[:, None] * frac[None, :]
        Y = sol.sol(T.ravel())
        G = np.array([value(Y[:, i]) for i in range(Y.shape[1])]).reshape(T.shape)
        hits = wanted(G[:, :-1], G[:, 1:]) & (T[:, :-1] < t_end)
        if hits.any():
            k, i = np.argwhere(hits)[0]
            return T[k, i], T[k, i + 1], G[k, i], G[k, i + 1]
    return None


def _down(g0, g1):
    return (g0 > 0) & (g1 < 0)


def _first_down(sol, t_end, value):
    """Earliest downward zero of value(y) on the dense output in [t0, t_end] (sampled), or None."""
    hit = _sampled_first(sol, t_end, value, _down)
    if hit is None:
        return None
    return _root(lambda t: value(sol.sol(t)), hit[0], hit[1])


@dataclasses.dataclass
class Phase:
    """One phase of a run: kind (ROLLING/SLIPPING), [t0, t1] [s] and scipy's dense output
    ``sol`` (an ``OdeSolution`` on [t0, >= t1]; state (beta, omega1, omega2, omega3, alpha)
    while rolling, (beta, omega1, omega2, omega3, u1, u3, alpha) while slipping)."""

    kind: int
    t0: float
    t1: float
    sol: object


IMPLICIT = ("Radau", "BDF", "LSODA")  # solve_ivp's methods that use a Jacobian


class _System:
    """The scipy systems of one run: right-hand sides, event values and ``solve_ivp`` events of the
    rolling and slipping phases, and the return rule, for one scene and the run's settings."""

    def __init__(self, params: Params, t_max, rtol, atol, method, switching_tolerances, terms=()):
        self.p = params.as_array()
        self.sw = switching.default_tolerances(**(switching_tolerances or {}))
        scene = scene_of(params, terms)
        self.hybrid = scene.slips
        self.conservative = not scene.dissipates(params)  # periodic rolling detected
        self.load_fn = scene_code.load_of(scene)  # the scene's external load (compiled), None without terms
        self.u_stop = self.sw[switching.SW_U_STOP]
        self.t_max, self.rtol, self.atol, self.method = t_max, rtol, atol, method
        self.out = np.empty(7)  # the rolling state of a return (try_return)
        self.fall_roll = scipy_event(self.fall_roll_value, terminal=True, direction=-1)
        self.omega1_zero = _omega1_zero()
        self.fall_slip = scipy_event(self.fall_slip_value, terminal=True, direction=-1)
        self.f2_min_roll = scipy_event(self.f2_rate_roll, terminal=False, direction=1)  # interior minima of F2
        self.f2_min_slip = scipy_event(self.f2_rate_slip, terminal=False, direction=1)
        self.refused = self._refused_event()
        # the rolling phase's events by name; only the terminal ones other than omega1 stop it early
        self.roll_events = {"fall": self.fall_roll, "minimum": self.f2_min_roll}
        if self.hybrid:
            self.roll_events["slip"] = scipy_event(self.margin_value, terminal=True, direction=-1)
        if self.conservative:
            self.roll_events["omega1"] = self.omega1_zero
        self.at = {name: i for i, name in enumerate(self.roll_events)}

    def load(self, y):
        """The load of the scene's terms at the state y (rolling layout of 5, slipping of 7), or None."""
        if self.load_fn is None:
            return None
        u1, u3 = (y[4], y[5]) if len(y) == 7 else (0.0, 0.0)
        return self.load_fn(y[0], y[1], y[2], y[3], u1, u3, self.p)

    def fun_roll(self, t, y):
        b, w1, w2, w3 = rolling.rolling_rhs(y[0], y[1], y[2], y[3], self.p, self.load(y))
        alpha_dot, _ = kinematics.angle_rates(y[0], y[1], y[3], 0.0, 0.0, self.p)
        return [b, w1, w2, w3, alpha_dot]

    def fun_slip(self, t, y):
        b, w1, w2, w3, du1, du3 = slipping.slipping_rhs(y[0], y[1], y[2], y[3], y[4], y[5], self.p, self.load(y))
        alpha_dot, _ = kinematics.angle_rates(y[0], y[1], y[3], y[4], y[5], self.p)
        return [b, w1, w2, w3, du1, du3, alpha_dot]

    def jac_slip(self, t, y):
        """The Jacobian of :meth:`fun_slip` (``slipping.slipping_jacobian``), for the implicit methods."""
        J = np.zeros((7, 7))
        slipping.slipping_jacobian(*(float(v) for v in y[:6]), self.p, J)
        return J

    def slip_options(self) -> dict:
        """What solve_ivp takes besides events in a slipping phase: the analytic Jacobian of (42) for
        an implicit method in a scene without terms (it changes the Newton iterations, not the
        solution; a scene with terms leaves it to scipy's finite differences)."""
        if self.method in IMPLICIT and self.load_fn is None:
            return {"jac": self.jac_slip}
        return {}

    def fall_roll_value(self, y):
        return rolling.normal_force(y[0], y[1], y[3], self.p, self.load(y))

    def margin_value(self, y):
        return rolling.friction_margin(y[0], y[1], y[2], y[3], self.p, self.load(y))

    def fall_slip_value(self, y):
        return slipping.slipping_normal_force(y[0], y[1], y[3], y[4], y[5], self.p, self.load(y))

    def f2_rate_roll(self, y):  # dF2/dt of (31)
        b, w1, _, w3 = rolling.rolling_rhs(y[0], y[1], y[2], y[3], self.p, self.load(y))
        return rolling.normal_force_rate(y[0], y[1], y[3], b, w1, w3, self.p)

    def f2_rate_slip(self, y):  # dF2/dt of (41)
        b, w1, _, w3, du1, du3 = slipping.slipping_rhs(y[0], y[1], y[2], y[3], y[4], y[5], self.p, self.load(y))
        return slipping.slipping_normal_force_rate(y[0], y[1], y[3], y[4], y[5], b, w1, w3, du1, du3, self.p)

    def return_dt(self, t, y):
        """try_return at (t, y): the time it advances (>= 0), or -1.0 (refused); rolling state in ``out``."""
        yy = np.ascontiguousarray(y, dtype=float)
        return switching.try_return(yy, self.p, self.sw, self.t_max - t, self.out, self.load_fn)

    def _refused_event(self):
        """+1 while the return is refused, -1 where it is allowed (depends on t: the time left caps it)."""
        def refused(t, y):
            if np.hypot(y[4], y[5]) > self.u_stop:
                return 1.0
            return 1.0 if self.return_dt(t, y) < 0.0 else -1.0

        refused.terminal = True
        refused.direction = -1
        return refused

    def solve_rolling(self, t, y):
        """solve_ivp of one rolling phase from (t, y): (solution, its transversal omega1 zeros, the
        pair of omega1 crossings that makes it periodic or None, rhs evaluations)."""
        t_start = t if self.conservative and _starts_crossing(y, self, self.rtol) else None
        # scipy reports a zero the phase starts at (omega1 = 0 exactly) as an event at t: it counts
        # towards the terminal count and is not a zero of the phase (t_start stands for it)
        at_start = int(y[1] == 0.0)
        self.omega1_zero.terminal = (1 if t_start is not None else 2) + at_start

        def run():
            sol = solve_ivp(self.fun_roll, (t, self.t_max), y, method=self.method, rtol=self.rtol, atol=self.atol,
                            events=list(self.roll_events.values()), dense_output=True)
            if not self.conservative:
                return sol, [], None
            later = sol.t_events[self.at["omega1"]] > t if at_start else slice(None)
            zeros = _transversal_zeros(sol.t_events[self.at["omega1"]][later], sol.y_events[self.at["omega1"]][later],
                                       self, self.rtol)
            crossings = ([t_start] if t_start is not None else []) + zeros
            return sol, zeros, (crossings[:2] if len(crossings) >= 2 else None)

        sol, zeros, pair = run()
        nfev = sol.nfev
        others = [self.at[k] for k in ("fall", "slip") if k in self.at]
        if pair is None and sol.status == 1 and not any(sol.t_events[i].size for i in others):
            self.omega1_zero.terminal = False  # a touching zero stopped it: on to t_max past omega1 zeros
            sol, zeros, pair = run()
            nfev += sol.nfev
        return sol, zeros, pair, nfev


@dataclasses.dataclass
class _Run:
    """The state of one run between phases, and what it has recorded so far."""

    y: np.ndarray
    t: float = 0.0
    slipping: bool = False
    done: bool = False
    outcome: int = ON_RIM_AT_T_MAX
    reason: str = "t_max"
    half_period: float = np.nan
    nfev: int = 0
    steps: list = dataclasses.field(default_factory=lambda: [0, 0])  # accepted steps rolling, slipping
    switches: int = 0
    slip_phases: int = 0
    slip_time: float = 0.0
    t_slip0: float = 0.0
    phases: list = dataclasses.field(default_factory=list)
    events: list = dataclasses.field(default_factory=lambda: [(0.0, "start")])

    def finish(self, reason: str, outcome: int | None = None) -> None:
        self.done = True
        self.reason = reason
        if outcome is not None:
            self.outcome = int(outcome)


def integrate(state, params: Params, t_max=20.0, rtol=1e-11, atol=1e-12, method="DOP853", *,
              switching_tolerances=None, max_switches=10_000, terms=()) -> dict:
    """One rolling initial state by ``solve_ivp``, phase by phase, in any scene.

    Returns dict(outcome, t_end, half_period, nfev, slip_phases, slip_time, energy_drift,
    switches, y_end, steps_rolling, steps_slipping, reason, phases, events): y_end the state at
    t_end in the layout of its phase; steps_* the accepted ``solve_ivp`` steps taken in each
    kind of phase up to the phase's end (the cost a method needs for the accuracy asked, without
    the engine's overheads: ``benchmarks/slipping_cost.py`` compares them across methods);
    ``reason`` the kind of the event that ended the run (or ``too_many_switches``,
    ``integration_failed``); ``phases`` the :class:`Phase` list and ``events`` the (t [s], kind)
    list, kinds of :data:`EVENT_KINDS` (``solver.analysis.phase_trace`` samples them).

    Every phase starts with the rules' ``rules.phase_start_action`` (fall, slip, steady motion or
    run), as in the compiled engine; only the integration and the event location differ. ``terms``:
    load terms of the scene table, as ``simulate(..., terms=...)`` takes them.
    """
    system = _System(params, t_max, rtol, atol, method, switching_tolerances, terms)
    run = _Run(y=np.array([*np.asarray(state, float), 0.0]))
    p = system.p
    E0 = rolling.energy(run.y[0], run.y[1], run.y[2], run.y[3], p)
    while not run.done:
        action = _start_action(system, run)
        if action == rules.FALL:
            _fall(system, run, run.y)
        elif action == rules.SLIP:
            _to_slipping(system, run, max_switches)
        elif action == rules.STEADY:
            run.finish("steady_motion", STEADY_MOTION)
        elif run.t >= t_max:
            run.done = True
        elif run.slipping:
            _slipping_phase(system, run, max_switches)
        else:
            _rolling_phase(system, run, max_switches)
    y = run.y
    if run.slipping:
        run.slip_time += run.t - run.t_slip0
        E1 = slipping.energy(y[0], y[1], y[2], y[3], y[4], y[5], p)
    else:
        E1 = rolling.energy(y[0], y[1], y[2], y[3], p)
    run.events.append((run.t, run.reason if run.reason in EVENT_KINDS else "t_max"))
    return {"outcome": int(run.outcome), "t_end": float(run.t), "half_period": run.half_period,
            "nfev": int(run.nfev), "slip_phases": run.slip_phases, "slip_time": float(run.slip_time),
            "energy_drift": _energy_drift(E0, E1, p), "switches": run.switches, "y_end": np.asarray(y, float),
            "steps_rolling": run.steps[0], "steps_slipping": run.steps[1], "reason": run.reason,
            "phases": run.phases, "events": run.events}


def _start_action(system: _System, run: _Run) -> int:
    """``rules.phase_start_action`` at the start of the current phase: FALL, SLIP, STEADY or RUN."""
    y = run.y
    if run.slipping:
        return int(rules.phase_start_action(False, system.hybrid, False, system.fall_slip_value(y), 1.0, False))
    first = run.t == 0.0 and run.switches == 0
    margin = system.margin_value(y) if system.hybrid else 1.0
    steady = first and bool(rules.on_steady_motion(y[0], y[1], y[2], y[3], system.p, system.load(y)))
    return int(rules.phase_start_action(True, system.hybrid, first, system.fall_roll_value(y), margin, steady))


def _fall(system: _System, run: _Run, y) -> None:
    """The ball separates at the state y: fall_in or fall_out by the free flight (``rules.fall_outcome``)."""
    u1, u3 = (y[4], y[5]) if run.slipping else (0.0, 0.0)
    run.finish("fall", rules.fall_outcome(y[0], y[1], y[3], u1, u3, system.p))


def _to_slipping(system: _System, run: _Run, max_switches: int) -> None:
    """The friction cone (39) is left at the current state: slipping starts (``switching.enter_slipping``)."""
    run.switches += 1
    if run.switches > max_switches:
        run.finish("too_many_switches")
        return
    y7 = np.empty(7)
    y7[:5] = run.y
    y7[5:] = 0.0
    switching.enter_slipping(y7, system.p, system.sw, system.load_fn)
    run.y = y7
    run.slipping = True
    run.slip_phases += 1
    run.t_slip0 = run.t
    run.events.append((run.t, "slip_onset"))


def _rolling_phase(system: _System, run: _Run, max_switches: int) -> None:
    """One rolling phase from the current state to its first event: a fall (F2 (31) crossing zero, or
    a dip below zero between two located minima), the slip onset (the friction margin (39), also
    sampled), periodic rolling (the second transversal omega1 zero) or the end of the integration."""
    hybrid, at = system.hybrid, system.at
    sol, zeros, pair, nfev = system.solve_rolling(run.t, run.y)
    run.nfev += nfev
    t_stop = float(sol.t[-1])
    cands = []  # (time, rule): 0 fall, 1 slip, 2 periodic; scipy's events and the sampled dips
    if sol.t_events[at["fall"]].size:
        cands.append((float(sol.t_events[at["fall"]][0]), 0))
    if hybrid and sol.t_events[at["slip"]].size:
        cands.append((float(sol.t_events[at["slip"]][0]), 1))
    if pair is not None:
        cands.append((pair[1], 2))
    t_dip = _first_dip(sol, system.fall_roll_value, sol.t_events[at["minimum"]], t_stop)
    if t_dip is not None:
        cands.append((t_dip, 0))
    t_dip = _first_down(sol, t_stop, system.margin_value) if hybrid else None
    if t_dip is not None:
        cands.append((t_dip, 1))
    t_ev, rule = min(cands) if cands else (t_stop, -1)
    run.steps[0] += _steps_before(sol, t_ev)
    run.phases.append(Phase(ROLLING, run.t, t_ev, sol.sol))
    run.events += [(z, "omega1_zero") for z in zeros if z <= t_ev]
    if not cands:
        run.t = t_stop
        run.y = sol.y[:, -1]
        run.finish("integration_failed" if sol.status < 0 else "t_max")
        return
    run.t = t_ev
    run.y = sol.sol(t_ev)
    if rule == 0:
        _fall(system, run, run.y)
    elif rule == 2:
        run.half_period = float(pair[1] - pair[0])
        run.finish("periodic", PERIODIC_ROLLING)
    else:
        _to_slipping(system, run, max_switches)


def _slipping_phase(system: _System, run: _Run, max_switches: int) -> None:
    """One slipping phase from the current state to its first event: a fall (F2 (41), also between
    minima) or the first time the return rule (``switching.try_return``) lets the ball roll again;
    then the return to rolling."""
    t, y = run.t, run.y
    if np.hypot(y[4], y[5]) <= system.u_stop and system.return_dt(t, y) >= 0.0:
        _to_rolling(system, run, t, max_switches)  # allowed at the start already
        return
    sol = solve_ivp(system.fun_slip, (t, system.t_max), y, method=system.method, rtol=system.rtol, atol=system.atol,
                    events=[system.fall_slip, system.refused, system.f2_min_slip], dense_output=True,
                    **system.slip_options())
    run.nfev += sol.nfev
    t_stop = float(sol.t[-1])
    cands = []  # (time, rule): 0 fall, 1 return
    if sol.t_events[0].size:
        cands.append((float(sol.t_events[0][0]), 0))
    t_dip = _first_dip(sol, system.fall_slip_value, sol.t_events[2], t_stop)
    if t_dip is not None:
        cands.append((t_dip, 0))
    t_allowed = _first_allowed(sol, t_stop, system.u_stop, system.return_dt)
    if t_allowed is None and sol.t_events[1].size:
        t_allowed = _bisect_allowed(sol, t, float(sol.t_events[1][0]), float(sol.t_events[1][0]), system.return_dt)
    if t_allowed is not None:
        cands.append((t_allowed, 1))
    t_ev, rule = min(cands) if cands else (t_stop, -1)
    run.steps[1] += _steps_before(sol, t_ev)
    run.phases.append(Phase(SLIPPING, t, t_ev, sol.sol))
    if not cands:
        run.t = t_stop
        run.y = sol.y[:, -1]
        run.finish("integration_failed" if sol.status < 0 else "t_max")
        return
    run.y = sol.sol(t_ev)
    if rule == 0:
        run.t = t_ev
        _fall(system, run, run.y)
        return
    _to_rolling(system, run, t_ev, max_switches)


def _to_rolling(system: _System, run: _Run, t_ret: float, max_switches: int) -> None:
    """The return to rolling at t_ret [s], an allowed time of the return rule."""
    dt = system.return_dt(t_ret, run.y)
    if dt < 0.0:  # cannot happen: t_ret is an allowed time
        raise RuntimeError("reference: the located return is refused")
    run.switches += 1
    if run.switches > max_switches:
        run.t = t_ret
        run.finish("too_many_switches")
        return
    run.y = system.out[:5].copy()
    run.t = t_ret + dt
    run.slip_time += run.t - run.t_slip0
    run.slipping = False
    run.events.append((run.t, "return_to_rolling"))


def reference_hybrid(state, params: Params, t_max=20.0, rtol=1e-11, atol=1e-12, method="DOP853", *,
                     switching_tolerances=None, max_switches=10_000):
    """:func:`integrate` in a hybrid scene (finite mu); ValueError in a rolling-only one."""
    if params.rolling_only:
        raise ValueError("reference_hybrid needs a finite mu (a hybrid scene)")
    return integrate(state, params, t_max, rtol, atol, method, switching_tolerances=switching_tolerances,
                     max_switches=max_switches)


def _steps_before(sol, t_end):
    """Accepted steps of a ``solve_ivp`` solution that start before t_end (the step holding t_end included)."""
    return int(np.searchsorted(sol.t, t_end, side="left"))


def _bisect_allowed(sol, t_lo, t_refused, t_allowed, return_dt):
    """First allowed return time in (t_refused, t_allowed] by bisection (t_allowed allowed).

    If t_refused == t_allowed, the bracket is first widened downwards to a refused time >= t_lo.
    """
    def allowed(t):
        return return_dt(t, sol.sol(t)) >= 0.0

    if not allowed(t_allowed):  # scipy's root may sit on the refused side of the jump: step across
        step = RETURN_XTOL_EPS * _EPS * max(abs(t_allowed), 1e-300)
        for _ in range(64):
            t_allowed += step
            step *= 2.0
            if allowed(t_allowed):
                break
        else:
            return None
    if t_refused >= t_allowed:
        step = RETURN_XTOL_EPS * _EPS * max(abs(t_allowed), 1e-300)
        t_refused = t_allowed
        while t_refused > t_lo:
            t_refused = max(t_lo, t_allowed - step)
            if not allowed(t_refused):
                break
            t_allowed = t_refused
            step *= 2.0
        else:
            return t_lo
    while t_allowed - t_refused > RETURN_XTOL_EPS * _EPS * max(abs(t_allowed), abs(t_refused)):
        mid = 0.5 * (t_refused + t_allowed)
        if not (t_refused < mid < t_allowed):
            break
        if allowed(mid):
            t_allowed = mid
        else:
            t_refused = mid
    return t_allowed


def _first_allowed(sol, t_end, u_stop, return_dt):
    """Earliest time on the dense output in [t0, t_end] where the return is allowed (sampled + bisected)."""
    ts = np.asarray(sol.t)
    frac = np.linspace(0.0, 1.0, GRAZE_SAMPLES + 1)
    n = len(ts) - 1
    t_prev = None
    for lo in range(0, n, _SAMPLE_CHUNK):
        hi = min(n, lo + _SAMPLE_CHUNK)
        a = ts[lo:hi]
        b = np.minimum(ts[lo + 1:hi + 1], t_end)
        if a[0] > t_end:
            return None
        T = (a[:, None] + (b - a)[:, None] * frac[None, :]).ravel()
        Y = sol.sol(T)
        near = np.hypot(Y[4], Y[5]) <= u_stop
        for i in np.flatnonzero(near):
            if T[i] > t_end:
                break
            if return_dt(T[i], Y[:, i]) >= 0.0:
                j = i - 1
                t_ref = T[j] if j >= 0 else t_prev
                if t_ref is None or t_ref >= T[i]:
                    t_ref = T[i]
                return _bisect_allowed(sol, ts[0], t_ref, T[i], return_dt)
        t_prev = T[-1]
    return None


def reference_one(state, params: Params, t_max=20.0, rtol=1e-11, atol=1e-12, method="DOP853", terms=()):
    """Outcome of one rolling initial state by ``solve_ivp`` in any scene.

    Returns dict(outcome, t_end, half_period, nfev, slip_phases, slip_time, energy_drift,
    steps_rolling, steps_slipping).
    """
    res = integrate(state, params, t_max, rtol, atol, method, terms=terms)
    for key in ("y_end", "switches", "reason", "phases", "events"):
        res.pop(key)
    return res


def reference(states, params: Params, t_max=20.0, rtol=1e-11, atol=1e-12, method="DOP853", terms=()):
    """``reference_one`` over an array (..., 4) of states: dict of arrays (outcome, t_end, half_period,
    nfev, slip_phases, slip_time, energy_drift)."""
    x = np.asarray(states, float)
    flat = x.reshape(-1, 4)
    rows = [reference_one(s, params, t_max, rtol, atol, method, terms) for s in flat]
    shape = x.shape[:-1]
    return {
        "outcome": np.array([r["outcome"] for r in rows], dtype=np.int8).reshape(shape),
        "t_end": np.array([r["t_end"] for r in rows]).reshape(shape),
        "half_period": np.array([r["half_period"] for r in rows]).reshape(shape),
        "nfev": np.array([r["nfev"] for r in rows]).reshape(shape),
        "slip_phases": np.array([r["slip_phases"] for r in rows], dtype=np.int32).reshape(shape),
        "slip_time": np.array([r["slip_time"] for r in rows]).reshape(shape),
        "energy_drift": np.array([r["energy_drift"] for r in rows]).reshape(shape),
    }
