"""One trajectory in time: the rolling/slipping phases of one initial state, sampled densely.

``solver.simulate`` returns what happened (outcome, t_end, ...) for millions of states; this
module shows how, for one. The phases come from ``solver.analysis.scipy_reference.integrate``, the scipy
reference of ``solver.simulate`` (the same compiled right-hand sides and switching maps, the
rules of ``solver.engine.rules``, scipy ``solve_ivp`` phase by phase; see that module for how every
event is located), which keeps every phase's dense output; :func:`trace` samples all of them on
one time grid and adds the derived quantities. The result's outcome and t_end agree with
``solver.simulate`` to the integration tolerances (``tests/solver/analysis/test_trace.py``); this path is for
looking at one trajectory, not for maps (a Python-level loop, about 0.1-1 s per trajectory).
"""

from __future__ import annotations

import numpy as np

from rimroll.solver._arguments import check_size
from rimroll.solver.analysis import scipy_reference
from rimroll.solver.analysis.scipy_reference import EVENT_KINDS, PHASE_MEANINGS, ROLLING, SLIPPING, Phase
from rimroll.solver.physics import rolling, slipping
from rimroll.solver.physics.params import P_MU, P_R_BALL, P_R_RIM, P_RHO, Params

__all__ = ["EVENT_KINDS", "PHASE_MEANINGS", "ROLLING", "SLIPPING", "Phase", "sample", "trace", "trace_phases"]


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
    ``half_period`` [s] (NaN unless periodic), ``reason`` (kind of the event that ended the run,
    or ``too_many_switches``), ``slip_phases``. RuntimeError if scipy's integration fails.
    """
    x0 = np.asarray(state, dtype=float)
    if x0.shape != (4,) or not np.all(np.isfinite(x0)):
        raise ValueError(f"state must be 4 finite numbers (beta, omega1, omega2, omega3); got {state!r}")
    if not (np.isfinite(t_max) and t_max > 0):
        raise ValueError(f"t_max must be a positive finite time [s]; got {t_max!r}")
    res = scipy_reference.integrate(x0, params, t_max, rtol, atol, method, max_switches=max_switches)
    if res["reason"] == "integration_failed":
        raise RuntimeError(f"trace: scipy's {method} failed in the phase from t = {res['phases'][-1].t0:g} s")
    return {k: res[k] for k in ("phases", "events", "outcome", "t_end", "half_period", "reason", "slip_phases")}


def sample(result: dict, params: Params, n: int = 2000) -> dict:
    """The phases of :func:`trace_phases` sampled on one time grid, with derived quantities.

    ``n`` points uniform in [0, t_end], plus every phase's start and end, sorted. Returns numpy
    arrays over time: t [s], beta [rad], omega1, omega2, omega3 [1/s], u1, u3 [m/s] (0 while
    rolling), alpha [rad], phase (ROLLING/SLIPPING), F2 [N], friction_use (|F_t| / (mu F2); 1
    while slipping, 0 with mu = inf), slip_speed [m/s], energy [J], and the ball centre's
    position x, y, z [m] (rim's axis vertical through the origin, rim's middle plane at z = 0).
    """
    check_n(n)
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


SAMPLED_COLUMNS = 24
"""Float arrays of n values that :func:`sample` holds at once (its columns and their intermediates)."""


def check_n(n) -> None:
    """ValueError naming ``n`` where its sampled columns would not fit in memory."""
    check_size("n", (max(int(n), 2), SAMPLED_COLUMNS), what="the sampled time series (n x columns)")


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
    check_n(n)  # before the integration
    res = trace_phases(state, params, t_max=t_max, rtol=rtol, atol=atol, method=method)
    out = sample(res, params, n)
    out.update({k: res[k] for k in ("outcome", "t_end", "half_period", "reason", "slip_phases")})
    out["event_t"] = np.array([e[0] for e in res["events"]])
    out["event_kind"] = np.array([e[1] for e in res["events"]])
    return out
