"""The rolling-only conservative scene in heyoka's expression system: a peer of rimroll's engine.

Used by the work-precision study (its integrator ``heyoka_taylor``) and by ``benchmarks/peers.py``; it
imports the solver only. Installed with rimroll as ``rimroll.peer_models.heyoka_rolling`` (the folder
``benchmarks/peer_models``), so the study finds it in any install.
heyoka (https://bluescarni.github.io/heyoka.py, the extra ``rimroll[bench]``) is imported only when
a model is built; this module imports without it, and :func:`available` says whether it is there.

The model
    State (beta, omega1, omega2, omega3, alpha); the rates (33)-(36) and alpha_dot of (19) with
    u1 = 0, and F2/m of (31), are written once (:func:`rates`, :func:`f2_over_m`) over any
    ``sin``/``cos``: heyoka's expressions build the integrator, numpy's evaluate the pre-checks.
    ``tests/workflows/test_heyoka_rolling.py`` (and ``benchmarks/peers.py`` before it times anything) checks
    them against ``solver.physics.rolling.rolling_rhs`` and ``normal_force`` to 1e-12.
The rules (docs/outcome-engine.md), as the engine applies them in this scene
    * phase start, before any integration: F2 < 0 (``rolling.normal_force``) falls at t = 0; a steady
      motion (``engine.rules``' residual, STEADY_TOL) is ``steady_motion`` at t = 0;
    * terminal events, each with a callback: F2 = 0 downward is the fall (in or out by the flight of
      ``solver.physics.flight``, applied afterwards from the state there); omega1 = 0 counts if
      ``rules.transversal_omega1_zero`` holds (rtol = heyoka's tol), and the second counted zero makes
      the orbit periodic; ``time = t0 + t_max`` is ``on_rim_at_t_max``.
heyoka's fastest route
    ``taylor_adaptive_batch`` at ``heyoka.recommended_simd_size()`` lanes; each callback records its
    lane's result and loads the next state into the lane (one ``propagate_until`` per run), and one
    forked process per core (:class:`Workers`) takes an interleaved share of the states.
Pitfalls (found on the Fig. 11 section; each one gave wrong outcomes or NaN steps)
    * heyoka refuses to change the time in a callback: a lane keeps running time, remembers its
      start t0 in double-length (hi, lo) and reports t_end = t - t0; t_max is the event
      ``time - par[0]`` with ``par[0] = t0 + t_max`` per lane.
    * The F2 event has ``cooldown=0``: heyoka's automatic cooldown outlives a refill and hid falls
      of the next state within ~1e-6 s (3, 10, 83 wrong cells at tol 1e-6, 1e-5, 1e-4). Safe, as
      every F2 trigger ends its lane's state.
    * Event functions enter heyoka's step-size control: a lane with nothing left to do is parked on
      a bounded orbit (omega1 = 100 1/s, F2 < 0 throughout) with ``par[0] = t + 1e5`` (a lane left on
      its old trajectory ran away to NaN, a ``par`` of 1e300 gave NaN steps).
"""

from __future__ import annotations

import importlib.util
import math
import multiprocessing
import os
import threading
import time
from typing import NamedTuple

import numpy as np

from rimroll.solver.engine import outcomes, rules
from rimroll.solver.physics import kinematics, rolling, steady_motion
from rimroll.solver.physics.params import Params

LABEL = "heyoka_taylor"
"""The integrator label of this model in the work-precision study."""

_PARKED = (0.3, 100.0, 1.0, 1.0, 0.0)  # an idle lane's state: omega1 = 100 1/s keeps F2 < 0, no events
_PARKED_HORIZON = 1e5  # [s] an idle lane's time event lies this far ahead


def available() -> bool:
    """Whether heyoka is installed (the extra ``rimroll[bench]``)."""
    return importlib.util.find_spec("heyoka") is not None


def unsupported(params: Params) -> str | None:
    """Why this model cannot run the scene of ``params`` (None: it can)."""
    if not params.rolling_only:
        return "the heyoka model is the rolling-only conservative scene (mu = inf); this scene slips (finite mu)"
    if params.dissipative:
        return "the heyoka model is the rolling-only conservative scene (k_r = k_d = 0); this scene dissipates"
    return None


class Constants(NamedTuple):
    """The numbers of ``Params`` the rolling equations read."""

    r: float
    R: float
    rho: float
    j: float
    g: float
    m: float

    @classmethod
    def of(cls, params: Params) -> Constants:
        return cls(params.r, params.R, params.rho, params.j, params.g, params.m)


def omega1_rate(beta, omega2, omega3, c: Constants, sin, cos):
    """omega1_dot of (33), written as ``solver.physics.rolling.rolling_rhs`` writes it (k_r = 0)."""
    s, co = sin(beta), cos(beta)
    D = c.R - c.rho * co
    return ((1.0 + c.j) * c.r * omega3 * omega3 * s - c.j * c.r * omega2 * omega3 * co) / ((1.0 + c.j) * D) \
        - c.g * co / (c.r * (1.0 + c.j))


def rates(beta, omega1, omega2, omega3, c: Constants, sin, cos):
    """(beta_dot, omega1_dot, omega2_dot, omega3_dot, alpha_dot) of (33)-(36), (19) with u1 = 0,
    for heyoka expressions (``sin``, ``cos`` = ``heyoka.sin``, ``heyoka.cos``) or numpy arrays."""
    s, co = sin(beta), cos(beta)
    D = c.R - c.rho * co
    return (c.r * omega1 / c.rho,
            omega1_rate(beta, omega2, omega3, c, sin, cos),
            c.r * c.R * omega1 * omega3 / (c.rho * D),
            -c.r * omega1 * omega3 * s / D - c.j * c.r * omega1 * omega2 / (c.rho * (1.0 + c.j)),
            -c.r * omega3 / D)


def f2_over_m(beta, omega1, omega3, c: Constants, sin, cos):
    """The normal force (31) over the mass [N/kg] (``rolling.normal_force`` / m): the ball separates where < 0."""
    co = cos(beta)
    return c.r * c.r * omega3 * omega3 * co / (c.R - c.rho * co) - c.r * c.r * omega1 * omega1 / c.rho + c.g * sin(beta)


def equations(params: Params):
    """heyoka's system [(variable, rate)], the F2/m expression and the variables
    (beta, omega1, omega2, omega3, alpha)."""
    import heyoka as hy

    c = Constants.of(params)
    v = hy.make_vars("beta", "omega1", "omega2", "omega3", "alpha")
    return list(zip(v, rates(*v[:4], c, hy.sin, hy.cos))), f2_over_m(v[0], v[1], v[3], c, hy.sin, hy.cos), v


def compiled_rates(params: Params):
    """The model's rates and F2 [N] compiled by heyoka (``heyoka.cfunc``): a function of states (n, 4)
    returning (rates (n, 5), F2 (n,)); what the integrator evaluates, for the checks against rimroll."""
    import heyoka as hy

    system, f2, v = equations(params)
    cf = hy.cfunc([rhs for _, rhs in system] + [f2], list(v))

    def evaluate(states):
        x = np.asarray(states, dtype=float)
        out = cf(np.ascontiguousarray(np.vstack([x.T, np.zeros(len(x))])))
        return out[:5].T, params.m * out[5]

    return evaluate


# ---- the rules of the engine, in numpy (their scales and tolerances from solver.engine.rules) --------


def starts(states: np.ndarray, params: Params) -> tuple[np.ndarray, np.ndarray]:
    """Phase-start rules at t = 0 for states (n, 4): (falls now: F2 < 0, steady motion), as boolean arrays."""
    p = params.as_array()
    b, w1, w2, w3 = states.T
    with np.errstate(divide="ignore", invalid="ignore"):
        fall = rolling.normal_force.py_func(b, w1, w3, p) < 0.0
        _, d1, d2, d3, _ = rates(b, w1, w2, w3, Constants.of(params), np.sin, np.cos)
        s = rules.omega_scale.py_func(w1, w2, w3, p)
        residual = np.maximum(np.maximum(np.abs(w1) / s, np.abs(d1) / rules.rate_scale.py_func(b, w1, w2, w3, p)),
                              np.maximum(np.abs(d2) / (s * s), np.abs(d3) / (s * s)))
    return fall, ~fall & (residual <= rules.STEADY_TOL)


def fall_outcomes(states: np.ndarray, params: Params) -> np.ndarray:
    """``rules.fall_outcome`` (u1 = u3 = 0) for separation states (n, >= 4): FALL_IN or FALL_OUT (int8)."""
    c = Constants.of(params)
    b, w1, w3 = states[:, 0], states[:, 1], states[:, 3]
    co, s = np.cos(b), np.sin(b)
    d, z = c.R - c.rho * co, c.rho * s
    beta_dot = c.r * w1 / c.rho
    v_rad, v_z, v_tan = beta_dot * c.rho * s, beta_dot * c.rho * co, -c.r * w3
    root = np.sqrt(v_z * v_z + 2.0 * c.g * np.maximum(z, 0.0))
    with np.errstate(divide="ignore", invalid="ignore"):
        tf = np.where(v_z >= 0.0, (v_z + root) / c.g, 2.0 * z / (root - v_z))
    tf = np.where(z <= 0.0, 0.0, tf)
    x, y = d + v_rad * tf, v_tan * tf
    return np.where(np.sqrt(x * x + y * y) < c.R, outcomes.FALL_IN, outcomes.FALL_OUT).astype(np.int8)


def transversal(beta, omega1, omega2, omega3, c: Constants, rtol: float) -> bool:
    """``rules.transversal_omega1_zero`` for one state in plain Python (called in heyoka's callbacks)."""
    s, co = math.sin(beta), math.cos(beta)
    D = c.R - c.rho * co
    scale = (abs(c.r * omega3 * omega3 * s / D) + abs(c.j * c.r * omega2 * omega3 * co / ((1.0 + c.j) * D))
             + c.g / (c.r * (1.0 + c.j)))
    return abs(omega1_rate(beta, omega2, omega3, c, math.sin, math.cos)) > rules.TRANSVERSAL_RTOL_FACTOR * rtol * scale


def energy_drift(states, result: dict, params: Params) -> np.ndarray:
    """|E(t_end) - E(0)| / max(|E(0)|, m g rho) from the initial ``states`` and a :func:`classify` result,
    as ``solver.simulate`` reports ``energy_drift`` (``rolling.energy``)."""
    x = np.asarray(states, dtype=float)
    p = params.as_array()
    e0 = rolling.energy.py_func(x[:, 0], x[:, 1], x[:, 2], x[:, 3], p)
    e1 = rolling.energy.py_func(result["beta_end"], result["omega1_end"], result["omega2_end"], result["omega3_end"], p)
    return np.abs(e1 - e0) / np.maximum(np.abs(e0), params.m * params.g * params.rho)


CHECK_RTOL = 1e-12
"""Largest relative difference allowed between the model's rates and F2 and rimroll's."""


def check_states(params: Params, n: int = 300, seed: int = 0) -> tuple[np.ndarray, np.ndarray]:
    """States for :func:`check_against_rimroll`: n random ones (beta in [-pi, pi], omega1, omega3 in
    [-30, 30] 1/s, omega2 in [-120, 120] 1/s), and n // 5 steady motions (47)-(48) whose omega2 is off by a
    relative 1e-14 ... 1e-3 (either sign): omega1_dot is small there, so the transversal and steady
    rules are met on both sides."""
    rng = np.random.default_rng(seed)
    x = np.column_stack([rng.uniform(-np.pi, np.pi, n), rng.uniform(-30.0, 30.0, n), rng.uniform(-120.0, 120.0, n),
                         rng.uniform(-30.0, 30.0, n)])
    k = n // 5
    near = steady_motion.steady_state(rng.uniform(0.3, 1.4, k), rng.uniform(5.0, 20.0, k), params)
    near[:, 2] *= 1.0 + rng.choice([-1.0, 1.0], k) * 10.0 ** rng.uniform(-14.0, -3.0, k)
    return x, near


def check_against_rimroll(params: Params, n: int = 300, seed: int = 0, rtols=(1e-6, 1e-9, 1e-12)) -> dict:
    """Check the model against rimroll's own functions at the states of :func:`check_states`:

    * heyoka's compiled rates and F2 (:func:`compiled_rates`) against ``rolling.rolling_rhs``,
      ``kinematics.alpha_rate`` and ``rolling.normal_force`` at the n random states, to
      :data:`CHECK_RTOL` relative (to the value, or to a millionth of the column's largest value);
    * the rules in numpy or plain Python against ``engine.rules`` at all the states: the phase-start
      falls and steady motions (:func:`starts`), the flight (:func:`fall_outcomes`) and
      :func:`transversal` at ``rtols``, identical answers.

    Returns the largest relative differences and the counts of differing answers; raises ValueError
    naming what fails."""
    x, near = check_states(params, n, seed)
    p = params.as_array()
    got_rates, got_f2 = compiled_rates(params)(x)
    want = np.array([(*rolling.rolling_rhs(b, w1, w2, w3, p), kinematics.alpha_rate(b, w3, 0.0, p))
                     for b, w1, w2, w3 in x])
    want_f2 = np.array([rolling.normal_force(b, w1, w3, p) for b, w1, _, w3 in x])
    report = {"random_states": n, "near_steady_states": len(near)}
    for name, got, ref in zip(("beta_dot", "omega1_dot", "omega2_dot", "omega3_dot", "alpha_dot", "F2"),
                              [*got_rates.T, got_f2], [*want.T, want_f2]):
        floor = 1e-6 * np.max(np.abs(ref))
        report[f"rel_diff_{name}"] = float(np.max(np.abs(got - ref) / np.maximum(np.abs(ref), floor)))
    x = np.vstack([x, near])
    want_fall = np.array([rolling.normal_force(b, w1, w3, p) < 0.0 for b, w1, _, w3 in x])
    fall, steady = starts(x, params)
    report["differs_fall_at_start"] = int(np.sum(fall != want_fall))
    report["differs_steady"] = int(np.sum(steady != np.array(
        [not f and bool(rules.on_steady_motion(*s, p)) for s, f in zip(x, want_fall)])))
    report["steady_states_checked"] = int(steady.sum())
    report["differs_fall_outcome"] = int(np.sum(fall_outcomes(x, params) != np.array(
        [rules.fall_outcome(b, w1, w3, 0.0, 0.0, p) for b, w1, _, w3 in x])))
    c = Constants.of(params)
    report["differs_transversal"] = int(sum(
        transversal(*s, c, rtol) != bool(rules.transversal_omega1_zero(*s, p, rtol)) for s in x for rtol in rtols))
    report["transversal_false_checked"] = int(sum(not transversal(*s, c, rtol) for s in x for rtol in rtols))
    failed = [f"{k} = {v:.3g}" for k, v in report.items() if k.startswith("rel_diff") and not v <= CHECK_RTOL]
    failed += [f"{k} = {v}" for k, v in report.items() if k.startswith("differs") and v]
    if failed:
        raise ValueError("the heyoka model differs from rimroll's physics or rules: " + ", ".join(failed))
    return report


# ---- the integrator and its lanes --------------------------------------------------------------------------

_FALL = -2  # a lane's record: fell here (in or out is decided afterwards, in numpy)


class Integrator:
    """heyoka's batch integrator of the scene at one tolerance (compiled by LLVM when built, or loaded
    from heyoka's disk cache); ``batch``: lanes (default ``heyoka.recommended_simd_size()``)."""

    def __init__(self, params: Params, tol: float, batch: int | None = None):
        import heyoka as hy

        reason = unsupported(params)
        if reason:
            raise ValueError(reason)
        self.params, self.tol, self.constants = params, float(tol), Constants.of(params)
        self.batch = int(batch or hy.recommended_simd_size())
        system, f2, v = equations(params)
        events = [
            hy.t_event_batch(f2, callback=_on_fall, direction=hy.event_direction.negative, cooldown=0.0),
            hy.t_event_batch(v[1], callback=_on_omega1_zero, direction=hy.event_direction.any),
            hy.t_event_batch(hy.time - hy.par[0], callback=_on_t_max, direction=hy.event_direction.positive),
        ]
        start = np.tile(np.array(_PARKED)[:, None], (1, self.batch))
        self.ta = hy.taylor_adaptive_batch(system, start, tol=self.tol, t_events=events,
                                           pars=np.full((1, self.batch), _PARKED_HORIZON))
        self.order = int(self.ta.order)


class _Run:
    """The state of one run, read by the callbacks (heyoka copies callback objects: they find it here)."""


_RUN = _Run()
_LOCK = threading.Lock()  # one run at a time per process: the callbacks share _RUN


def _load(i: int) -> bool:
    """Load the next state into lane i, or park the lane. Returns whether any lane is still busy."""
    R = _RUN
    hi, lo = R.hi[i], R.lo[i]
    if R.next < R.n:
        k = R.next
        R.next += 1
        R.st[0:4, i] = R.x[k]
        R.st[4, i] = 0.0
        R.t0hi[i], R.t0lo[i] = hi, lo
        R.lane[i] = k
        R.crossings[i] = 0
        if R.x[k, 1] == 0.0 and transversal(*R.x[k], R.constants, R.tol):  # the engine's rule: a first crossing
            R.crossings[i], R.t1[i] = 1, 0.0
        R.pars[0, i] = hi + R.t_max
        return True
    if R.lane[i] >= 0:
        R.lane[i] = -1
        R.busy -= 1
    R.st[:, i] = _PARKED
    R.pars[0, i] = hi + _PARKED_HORIZON
    return R.busy > 0


def _finish(i: int, k: int, code: int) -> bool:
    """Record state k (in lane i) as ended with ``code`` now, and load the next one."""
    R = _RUN
    R.t_end[k] = (R.hi[i] - R.t0hi[i]) + (R.lo[i] - R.t0lo[i])
    R.end[k] = R.st[0:4, i]
    R.outcome[k] = code
    R.events += 1
    return _load(i)


def _on_fall(ta, d_sgn, i):
    k = _RUN.lane[i]
    return _finish(i, k, _FALL) if k >= 0 else _RUN.busy > 0


def _on_omega1_zero(ta, d_sgn, i):
    R = _RUN
    k = R.lane[i]
    if k < 0:
        return R.busy > 0
    R.events += 1
    st = R.st
    t = (R.hi[i] - R.t0hi[i]) + (R.lo[i] - R.t0lo[i])
    if t == 0.0 or not transversal(st[0, i], st[1, i], st[2, i], st[3, i], R.constants, R.tol):
        return True  # (at t = 0: a zero of the initial state, which _load has counted if it crosses)
    R.crossings[i] += 1
    if R.crossings[i] == 1:
        R.t1[i] = t
        return True
    R.half[k] = t - R.t1[i]
    return _finish(i, k, outcomes.PERIODIC_ROLLING)


def _on_t_max(ta, d_sgn, i):
    R = _RUN
    k = R.lane[i]
    if k < 0:
        R.pars[0, i] += _PARKED_HORIZON
        return R.busy > 0
    return _finish(i, k, outcomes.ON_RIM_AT_T_MAX)


def _integrate(integrator: Integrator, x: np.ndarray, t_max: float) -> dict:
    """Every row of x (past the phase-start rules) through the integrator's lanes, in this process."""
    with _LOCK:
        return _lanes(integrator, x, t_max)


def _lanes(integrator: Integrator, x: np.ndarray, t_max: float) -> dict:
    ta, B, R = integrator.ta, integrator.batch, _RUN
    R.x, R.n, R.next, R.t_max = np.ascontiguousarray(x), len(x), 0, float(t_max)
    R.tol, R.constants = integrator.tol, integrator.constants
    R.t_end, R.half = np.full(R.n, np.nan), np.full(R.n, np.nan)
    R.end = np.full((R.n, 4), np.nan)
    R.outcome = np.full(R.n, -1, dtype=np.int8)
    R.t0hi, R.t0lo, R.t1 = np.zeros(B), np.zeros(B), np.zeros(B)
    R.crossings = np.zeros(B, dtype=np.int64)
    R.lane = np.full(B, -1, dtype=np.int64)
    R.events = 0
    ta.set_time(np.zeros(B))
    ta.reset_cooldowns()
    R.st, R.pars = ta.state, ta.pars  # live views (building them in every callback cost 60 % more time)
    R.hi, R.lo = ta.dtime
    R.busy = min(B, R.n)
    for i in range(B):
        _load(i)
    steps = 0
    while R.busy > 0:
        ta.propagate_until(1e15)
        steps += sum(int(res[3]) for res in ta.propagate_res)  # lane-steps
    return {"t_end": R.t_end, "half_period": R.half, "outcome": R.outcome, "end": R.end, "steps": steps,
            "events": R.events}


# ---- runs of many states, in this process or in forked workers ----------------------------------------------

_FORKED = {}  # what forked workers inherit: the integrators built before the fork and the states


class Workers:
    """One forked process per core (or ``n``) that inherits the integrators built so far and ``states``;
    :func:`classify` hands each an interleaved share of those states. Use as a context manager."""

    def __init__(self, states: np.ndarray, integrators, n: int | None = None):
        _FORKED["states"] = states
        _FORKED["integrators"] = {id(ig): ig for ig in integrators}
        self.states, self.n = states, int(n or os.cpu_count() or 1)
        self.pool = multiprocessing.get_context("fork").Pool(self.n)

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        self.pool.close()
        self.pool.join()


def _worker(job):
    key, rows, t_max = job
    cpu = time.process_time()
    out = _integrate(_FORKED["integrators"][key], _FORKED["states"][rows], t_max)
    out["cpu_s"] = time.process_time() - cpu
    return rows, out


def classify(states, integrator: Integrator, t_max: float, workers: Workers | None = None) -> dict:
    """The outcome of every rolling state (n, 4) by the engine's rules with heyoka's integrator.

    Returns numpy arrays ``outcome`` (int8, ``solver.OUTCOME_MEANINGS``), ``t_end`` [s], ``half_period``
    [s] (NaN unless periodic), ``beta_end``, ``omega1_end``, ``omega2_end``, ``omega3_end`` (the state at
    t_end), and the counts ``integrated``, ``steps`` (lane-steps), ``events`` and ``worker_cpu_s``.
    With ``workers``, ``states`` must be the array the workers were made with."""
    x = np.asarray(states, dtype=float)
    fall, steady = starts(x, integrator.params)
    outcome = np.full(len(x), outcomes.STEADY_MOTION, dtype=np.int8)
    t_end, half, end = np.zeros(len(x)), np.full(len(x), np.nan), x.copy()
    todo = np.nonzero(~fall & ~steady)[0]
    if workers is None:
        parts = [(todo, _integrate(integrator, x[todo], t_max))]
        parts[0][1]["cpu_s"] = 0.0  # spent in this process
    else:
        if workers.states is not states or id(integrator) not in _FORKED["integrators"]:
            raise ValueError("the workers were made for other states or before this integrator was built")
        jobs = [(id(integrator), todo[c::workers.n], t_max) for c in range(workers.n)]
        parts = workers.pool.map(_worker, jobs)
    info = {"integrated": int(todo.size), "steps": 0, "events": 0, "worker_cpu_s": 0.0}
    for rows, out in parts:
        t_end[rows], half[rows], end[rows], outcome[rows] = out["t_end"], out["half_period"], out["end"], out["outcome"]
        info["steps"] += out["steps"]
        info["events"] += out["events"]
        info["worker_cpu_s"] += out["cpu_s"]
    fell = fall | (outcome == _FALL)
    outcome[fell] = fall_outcomes(end[fell], integrator.params)
    result = {"outcome": outcome, "t_end": t_end, "half_period": half}
    result.update({f"{name}_end": end[:, q] for q, name in enumerate(("beta", "omega1", "omega2", "omega3"))})
    return {**result, **info}
