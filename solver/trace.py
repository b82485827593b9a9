"""One trajectory in time: the rolling/slipping phases of one initial state, sampled densely.

``solver.simulate`` returns what happened (outcome, t_end, ...) for millions of states; this
module shows how, for one. It integrates the same physics, the compiled right-hand sides and
switching maps (``solver.rolling``, ``solver.slipping``, ``solver.switching``,
``solver.kinematics``, ``solver.flight``), phase by phase with scipy ``solve_ivp`` and its dense
output, under the rules of ``solver.simulate`` (paper Sect. 5.2.2; the steady-motion test and what counts
as a transversal omega1 zero are ``solver.rules``, shared with the engine):

* rolling: stop where F2 (31) crosses zero downward (fall: in or out by the free flight of the
  centre), where the friction margin (39) crosses zero downward (slip onset: the launch of
  ``switching.enter_slipping``), or, in conservative scenes, at the second transversal zero of
  omega1 within one rolling phase (periodic rolling, Prop. 4);
* slipping: stop where F2 (41) crosses zero downward (fall) or at the first time
  ``switching.try_return`` allows the return to rolling;
* otherwise on the rim at t_max.

Downward crossings are also searched on the dense output between step ends (a dip below zero
inside one step is not missed). Every phase keeps its dense output, and :func:`trace` samples
all of them on one time grid. The result's outcome and t_end agree with ``solver.simulate`` to
the integration tolerances (``tests/test_trace.py``); this path is for looking at one
trajectory, not for maps (a Python-level loop, about 0.1-1 s per trajectory).
"""

from __future__ import annotations

import dataclasses

import numpy as np
from scipy.integrate import solve_ivp
from scipy.optimize import brentq

from solver import flight, kinematics, rolling, rules, slipping, switching
from solver.reference import scipy_event
from solver.outcomes import ON_RIM_AT_T_MAX, PERIODIC_ROLLING, STEADY_MOTION
from solver.params import P_MU, P_R_BALL, P_R_RIM, P_RHO, Params

ROLLING, SLIPPING = 0, 1
PHASE_MEANINGS = {ROLLING: "rolling", SLIPPING: "slipping"}

EVENT_KINDS = ("start", "slip_onset", "return_to_rolling", "omega1_zero", "fall", "periodic", "t_max", "steady_motion")
"""Kinds of the events of a trace, in the order of their integer codes."""

_SAMPLES_PER_STEP = 16  # dense-output samples per step when searching a missed downward crossing


@dataclasses.dataclass
class Phase:
    """One phase of a trace: kind (ROLLING/SLIPPING), [t0, t1] [s] and its dense output."""

    kind: int
    t0: float
    t1: float
    sol: object  # scipy OdeSolution on [t0, >= t1]; state layout of the phase (see module docstring)


def _first_down(sol, ts, t1, value):
    """Earliest downward zero of value(y) on the dense output over the steps ``ts`` up to t1, or None."""
    frac = np.linspace(0.0, 1.0, _SAMPLES_PER_STEP + 1)
    for a, b in zip(ts[:-1], ts[1:]):
        if a >= t1:
            break
        t = a + (min(b, t1) - a) * frac
        g = np.array([value(y) for y in sol(t).T])
        hit = np.flatnonzero((g[:-1] > 0) & (g[1:] < 0))
        if hit.size:
            k = hit[0]
            f = lambda s: value(sol(s))
            return brentq(f, t[k], t[k + 1], xtol=1e-15) if f(t[k]) > 0 > f(t[k + 1]) else t[k + 1]
    return None


def trace_phases(state, params: Params, t_max: float = 20.0, rtol: float = 1e-10, atol: float = 1e-12,
                 method: str = "DOP853", max_switches: int = 10_000) -> dict:
    """Integrate one rolling initial state phase by phase; keep every phase's dense output.

    Parameters
    ----------
    state : array_like (4,)
        (beta [rad], omega1, omega2, omega3 [1/s]), a rolling state (u1 = u3 = 0).
    params : Params
        The scene: mu = inf never slips; k_r = k_d = 0 turns periodic detection on.
    t_max : float [s]; rtol, atol, method
        Passed to ``scipy.integrate.solve_ivp``.

    Returns
    -------
    dict: ``phases`` (list of :class:`Phase`), ``events`` (list of (t [s], kind) with kind in
    :data:`EVENT_KINDS`), ``outcome`` (code of ``solver.OUTCOME_MEANINGS``), ``t_end`` [s],
    ``half_period`` [s] (NaN unless periodic), ``reason`` (kind of the event that ended the run),
    ``slip_phases``.
    """
    x0 = np.asarray(state, dtype=float)
    if x0.shape != (4,) or not np.all(np.isfinite(x0)):
        raise ValueError(f"state must be 4 finite numbers (beta, omega1, omega2, omega3); got {state!r}")
    if not (np.isfinite(t_max) and t_max > 0):
        raise ValueError(f"t_max must be a positive finite time [s]; got {t_max!r}")
    p = params.as_array()
    sw = switching.default_tolerances()
    u_stop = sw[switching.SW_U_STOP]
    conservative = not params.dissipative
    hybrid = not params.rolling_only

    def fun_roll(t, y):
        b, w1, w2, w3 = rolling.rolling_rhs(y[0], y[1], y[2], y[3], p)
        alpha_dot, _ = kinematics.angle_rates(y[0], y[1], y[3], 0.0, 0.0, p)
        return [b, w1, w2, w3, alpha_dot]

    def fun_slip(t, y):
        b, w1, w2, w3, du1, du3 = slipping.slipping_rhs(y[0], y[1], y[2], y[3], y[4], y[5], p)
        alpha_dot, _ = kinematics.angle_rates(y[0], y[1], y[3], y[4], y[5], p)
        return [b, w1, w2, w3, du1, du3, alpha_dot]

    f2_roll = lambda y: rolling.normal_force(y[0], y[1], y[3], p)
    margin = lambda y: rolling.friction_margin(y[0], y[1], y[2], y[3], p)
    f2_slip = lambda y: slipping.slipping_normal_force(y[0], y[1], y[3], y[4], y[5], p)
    out = np.empty(7)

    def return_dt(t, y):
        return switching.try_return(np.ascontiguousarray(y, dtype=float), p, sw, t_max - t, out)

    def refused(y, t):
        return 1.0 if np.hypot(y[4], y[5]) > u_stop or return_dt(t, y) < 0.0 else -1.0

    phases, events = [], [(0.0, "start")]
    y = np.array([*x0, 0.0])
    t, slipping_now, switches, slip_phases = 0.0, False, 0, 0
    outcome, half_period, reason = ON_RIM_AT_T_MAX, np.nan, "t_max"
    while True:
        if not slipping_now:
            if f2_roll(y) < 0.0:
                outcome, reason = int(flight.flight_outcome(y[0], y[1], y[3], 0.0, 0.0, p)), "fall"
                break
            if hybrid and margin(y) < 0.0:
                slipping_now, y = True, _to_slipping(y, p, sw)
                slip_phases += 1
                events.append((t, "slip_onset"))
                continue
            if t == 0.0 and rules.on_steady_motion(y[0], y[1], y[2], y[3], p):  # solver.rules, as simulate
                outcome, reason = STEADY_MOTION, "steady_motion"
                break
            if t >= t_max:
                break
            evs = [scipy_event(f2_roll, terminal=True, direction=-1)]
            if hybrid:
                evs.append(scipy_event(margin, terminal=True, direction=-1))
            if conservative:
                evs.append(scipy_event(lambda y: y[1], terminal=2, direction=0))  # a touching zero may stop it early
            sol = solve_ivp(fun_roll, (t, t_max), y, method=method, rtol=rtol, atol=atol, events=evs,
                            dense_output=True)
            if sol.status < 0:
                raise RuntimeError(f"trace: rolling phase from t = {t:g} s failed: {sol.message}")
            t_stop = float(sol.t[-1])
            cands = [(float(sol.t_events[0][0]), "fall")] if sol.t_events[0].size else []
            if hybrid and sol.t_events[1].size:
                cands.append((float(sol.t_events[1][0]), "slip_onset"))
            zeros = np.array([z for z, yz in zip(sol.t_events[-1], sol.y_events[-1])  # transversal ones only
                              if rules.transversal_omega1_zero(yz[0], yz[1], yz[2], yz[3], p, rtol)]
                             ) if conservative else np.empty(0)
            if zeros.size >= 2:
                cands.append((float(zeros[1]), "periodic"))
            for value, kind in ((f2_roll, "fall"), (margin, "slip_onset")) if hybrid else ((f2_roll, "fall"),):
                dip = _first_down(sol.sol, sol.t, t_stop, value)
                if dip is not None:
                    cands.append((float(dip), kind))
            t_ev, kind = min(cands) if cands else (t_stop, "t_max")
            phases.append(Phase(ROLLING, t, t_ev, sol.sol))
            events += [(float(z), "omega1_zero") for z in zeros if z <= t_ev]
            t, y = t_ev, sol.sol(t_ev)
            if kind == "t_max":
                break
            if kind == "fall":
                outcome, reason = int(flight.flight_outcome(y[0], y[1], y[3], 0.0, 0.0, p)), "fall"
                break
            if kind == "periodic":
                outcome, reason, half_period = PERIODIC_ROLLING, "periodic", float(zeros[1] - zeros[0])
                break
            switches += 1
            if switches > max_switches:
                reason = "too_many_switches"
                break
            slipping_now, y = True, _to_slipping(y, p, sw)
            slip_phases += 1
            events.append((t, "slip_onset"))
        else:
            if f2_slip(y) < 0.0:
                outcome, reason = int(flight.flight_outcome(y[0], y[1], y[3], y[4], y[5], p)), "fall"
                break
            if t >= t_max:
                break
            if refused(y, t) < 0:
                t_ret = t
            else:
                def ret(s, z):  # +1 while the return is refused, -1 once allowed
                    return refused(z, s)

                ret.direction, ret.terminal = -1, True
                sol = solve_ivp(fun_slip, (t, t_max), y, method=method, rtol=rtol, atol=atol,
                                events=[scipy_event(f2_slip, terminal=True, direction=-1), ret],
                                dense_output=True)
                sol_ev = sol.t_events  # the return event: a jump of refused() from +1 to -1
                if sol.status < 0:
                    raise RuntimeError(f"trace: slipping phase from t = {t:g} s failed: {sol.message}")
                t_stop = float(sol.t[-1])
                cands = [(float(sol_ev[0][0]), "fall")] if sol_ev[0].size else []
                dip = _first_down(sol.sol, sol.t, t_stop, f2_slip)
                if dip is not None:
                    cands.append((float(dip), "fall"))
                t_ret = _first_allowed(sol, t, t_stop, refused)
                if t_ret is None and sol_ev[1].size:  # allowed only in a sliver around scipy's event
                    t_ret = _allowed_near(sol.sol, float(sol_ev[1][0]), t, refused)
                if t_ret is not None:
                    cands.append((t_ret, "return_to_rolling"))
                t_ev, kind = min(cands) if cands else (t_stop, "t_max")
                phases.append(Phase(SLIPPING, t, t_ev, sol.sol))
                t, y = t_ev, sol.sol(t_ev)
                if kind == "t_max":
                    break
                if kind == "fall":
                    outcome, reason = int(flight.flight_outcome(y[0], y[1], y[3], y[4], y[5], p)), "fall"
                    break
            dt = return_dt(t_ret, y)
            switches += 1
            if dt < 0.0 or switches > max_switches:
                reason = "too_many_switches" if dt >= 0.0 else "return_refused"
                break
            y = out[:5].copy()
            t = t_ret + dt
            slipping_now = False
            events.append((t, "return_to_rolling"))
    events.append((t, reason if reason in EVENT_KINDS else "t_max"))
    return {"phases": phases, "events": events, "outcome": int(outcome), "t_end": float(t),
            "half_period": half_period, "reason": reason, "slip_phases": slip_phases}


def _to_slipping(y5, p, sw):
    y7 = np.zeros(7)
    y7[:5] = y5
    switching.enter_slipping(y7, p, sw)
    return y7


def _first_allowed(sol, t0, t1, refused):
    """First time in [t0, t1] at which the return to rolling is allowed (sampled, then bisected), or None."""
    frac = np.linspace(0.0, 1.0, _SAMPLES_PER_STEP + 1)
    prev = t0
    for a, b in zip(sol.t[:-1], sol.t[1:]):
        if a > t1:
            break
        ts = a + (min(b, t1) - a) * frac
        for s in ts:
            if refused(sol.sol(s), s) < 0:
                lo, hi = prev, s
                for _ in range(200):
                    if hi - lo <= 4 * np.finfo(float).eps * max(abs(hi), 1.0):
                        break
                    mid = 0.5 * (lo + hi)
                    if refused(sol.sol(mid), mid) < 0:
                        hi = mid
                    else:
                        lo = mid
                return float(hi)
            prev = s
    return None


def _allowed_near(sol, t_event, t_lo, refused):
    """An allowed return time next to scipy's located jump t_event (stepping across it), or None."""
    step = 4 * np.finfo(float).eps * max(abs(t_event), 1.0)
    for t in (t_event, *(t_event + step * 2.0 ** k for k in range(60)), *(t_event - step * 2.0 ** k for k in range(60))):
        if t >= t_lo and refused(sol(t), t) < 0:
            return float(t)
    return None


def sample(result: dict, params: Params, n: int = 2000) -> dict:
    """The phases of :func:`trace_phases` sampled on one time grid, with derived quantities.

    ``n`` points uniform in [0, t_end], plus every phase's start and end, sorted. Returns numpy
    arrays over time: t [s], beta [rad], omega1, omega2, omega3 [1/s], u1, u3 [m/s] (0 while
    rolling), alpha [rad], phase (ROLLING/SLIPPING), F2 [N], friction_use (|F_t| / (mu F2); 1
    while slipping, 0 with mu = inf), slip_speed [m/s], energy [J], and the ball centre's
    position x, y, z [m] (rim's axis vertical through the origin, rim's middle plane at z = 0).
    """
    p = params.as_array()
    t_end = result["t_end"]
    grid = [np.linspace(0.0, t_end, max(int(n), 2))]
    grid += [np.array([ph.t0, ph.t1]) for ph in result["phases"]]
    ts = np.unique(np.concatenate(grid))
    cols = {k: np.full(ts.size, np.nan) for k in ("beta", "omega1", "omega2", "omega3", "u1", "u3", "alpha")}
    phase = np.full(ts.size, -1, dtype=np.int8)
    for ph in result["phases"]:
        sel = (ts >= ph.t0) & (ts <= ph.t1)
        if not sel.any():
            continue
        Y = ph.sol(ts[sel])
        cols["beta"][sel], cols["omega1"][sel], cols["omega2"][sel], cols["omega3"][sel] = Y[:4]
        if ph.kind == SLIPPING:
            cols["u1"][sel], cols["u3"][sel], cols["alpha"][sel] = Y[4], Y[5], Y[6]
        else:
            cols["u1"][sel], cols["u3"][sel], cols["alpha"][sel] = 0.0, 0.0, Y[4]
        phase[sel] = ph.kind
    keep = phase >= 0  # the instants of a return's extrapolated step belong to no phase
    ts, phase = ts[keep], phase[keep]
    c = {k: v[keep] for k, v in cols.items()}
    b, w1, w2, w3, u1, u3 = (c[k] for k in ("beta", "omega1", "omega2", "omega3", "u1", "u3"))
    slip = phase == SLIPPING
    f2 = np.where(slip, _vec(slipping.slipping_normal_force, b, w1, w3, u1, u3, p),
                  _vec(rolling.normal_force, b, w1, w3, p))
    F1, _, F3 = _vec3(rolling.contact_forces, b, w1, w2, w3, p)
    mu = p[P_MU]
    with np.errstate(divide="ignore", invalid="ignore"):
        use = np.where(slip, 1.0, np.hypot(F1, F3) / (mu * f2)) if np.isfinite(mu) else np.zeros(ts.size)
    energy = np.where(slip, _vec(slipping.energy, b, w1, w2, w3, u1, u3, p), _vec(rolling.energy, b, w1, w2, w3, p))
    d = p[P_R_RIM] - p[P_RHO] * np.cos(b)
    return {"t": ts, **c, "phase": phase, "F2": f2, "friction_use": use, "slip_speed": np.hypot(u1, u3),
            "energy": energy, "x": d * np.cos(c["alpha"]), "y": d * np.sin(c["alpha"]),
            "z": p[P_RHO] * np.sin(b), "r_ball": p[P_R_BALL]}


def _vec(f, *args):
    """A compiled scalar kernel applied elementwise over numpy arrays (last argument: p)."""
    *arrays, p = args
    return np.array([f(*vals, p) for vals in zip(*arrays)], dtype=float)


def _vec3(f, *args):
    *arrays, p = args
    out = np.array([f(*vals, p) for vals in zip(*arrays)], dtype=float).reshape(-1, 3)
    return out[:, 0], out[:, 1], out[:, 2]


def trace(state, params: Params, t_max: float = 20.0, rtol: float = 1e-10, atol: float = 1e-12,
          n: int = 2000, method: str = "DOP853") -> dict:
    """:func:`trace_phases` then :func:`sample`: one trajectory as time series plus its summary.

    Returns the dict of :func:`sample` plus ``outcome``, ``t_end`` [s], ``half_period`` [s],
    ``reason``, ``slip_phases``, ``event_t`` [s] and ``event_kind`` (strings of
    :data:`EVENT_KINDS`).
    """
    res = trace_phases(state, params, t_max=t_max, rtol=rtol, atol=atol, method=method)
    out = sample(res, params, n)
    out.update({k: res[k] for k in ("outcome", "t_end", "half_period", "reason", "slip_phases")})
    out["event_t"] = np.array([e[0] for e in res["events"]])
    out["event_kind"] = np.array([e[1] for e in res["events"]])
    return out
