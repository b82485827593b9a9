"""Types of the solutions of the rolling ball (paper Sect. 4.4, Theorem 1, Table 2).

The classification is about the conservative rolling equations (33)-(36) as a mathematical
system: falling (F2 < 0) and slipping are NOT considered (paper Sect. 4), so it integrates
:func:`solver.rolling.rolling_rhs` itself (``solver.analysis.trajectory``) instead of ``solver.simulate``,
which stops at a fall. The phase space is (beta, omega1, omega2, omega3) with beta an angle;
the angle alpha round the rim is not part of it (paper Sect. 4.1).

Codes (int8; CF ``flag_values`` / ``flag_meanings`` in files) are the items of Theorem 1:

0 undetermined              none of the below within t_max: a slow periodic orbit, a connection
                            or a rotation not yet resolved, or a failed integration
1 trivial_equilibrium       f(x) = 0 with cos(beta) = 0, omega1 = omega3 = 0 (46); any omega2
2 nontrivial_equilibrium    f(x) = 0 with omega1 = 0, omega3 != 0, omega2 = omega20(beta, omega3) (47)-(48)
3 trivial_connection        the solution tends to the unstable trivial equilibrium x0+ (ball on
                            top, beta = pi/2): a homoclinic or heteroclinic connection of it,
                            e.g. the separatrix E = m g rho of the pendulum (Prop. 6)
4 nontrivial_connection     the solution tends to an unstable (saddle, h > 0 in (54)) steady
                            motion: a homoclinic or heteroclinic connection of it
5 non_periodic_pendulum     omega2 = omega3 = 0 and E > m g rho (Prop. 6; the paper prints m g r,
                            the conserved energy has m g rho, docs/outcome-studies.md): omega1 never changes sign
6 periodic                  omega1 has two transversal zeros within t_max: periodic with period
                            2 (t2 - t1) (Prop. 4), or a rotation (omega1 keeps its sign, Prop. 5)
                            that closes after q revolutions of beta
7 quasi_periodic            a rotation whose (omega2, omega3), sampled once per revolution of
                            beta, turns by an irrational fraction of a full turn (Props. 5, 7;
                            only in the stable region of Fig. 9)

How each is decided, and what "within resolution" means:

* Equilibria (1, 2) have ``rules.steady_residual`` <= eq_tol (relative), a trivial one also
  |omega3| <= eq_tol S with S = ``rules.omega_scale``; the pendulum tests (3, 5) compare omega2,
  omega3 with eq_tol S and E with m g rho to eq_tol.
* Connections (3, 4). Along a solution (omega2, omega3) is a function of beta fixed by the
  conserved P_I, P_II, and (beta, omega1) obey a planar conservative system
  (``solver.analysis.reduced``) whose saddles are the unstable equilibria of Theorem 1. The solution is
  integrated (DOP853 at rtol) up to its second omega1 zero or t_max; where it comes close to an
  equilibrium, the equilibrium x* on its level of (P_I, P_II) is found by Newton's method
  (``reduced.equilibrium``). It is a connection if x* is a saddle, the scaled distance
  d(t) = max(|beta - beta*|, |omega - omega*| / S) falls below ``connection_tol`` (default
  CONNECTION_TOL_FACTOR sqrt(rtol): an integration at rtol leaves the stable manifold by ~rtol
  and then misses the saddle by ~sqrt(rtol)), and ln d(t) falls with the slope -lambda of the
  saddle (sqrt(h) of (54), sqrt(g/(rho (1+j))) at x0+) to within RATE_TOL over the decades from
  WINDOW_TOP down to 10 d_min. What the integration does after the closest approach (it leaves
  the saddle, driven by the round-off) is not used. A connection is homoclinic if its orbit
  crosses omega1 = 0 transversally anywhere (then by (61) its two ends are the same
  equilibrium), heteroclinic if the backward solution (integrated as the forward one of the
  mirror state (beta, -omega1, omega2, omega3), (61)) tends to another equilibrium.
* Periodic by Prop. 4 (6): two zeros of omega1, both transversal by
  ``rules.transversal_omega1_zero`` at the integration's rtol.
* Rotations (6, 7): omega1 keeps its sign up to t_max and beta makes at least MIN_REVOLUTIONS
  revolutions. Then (62) holds exactly, so the values z_k of (omega2, omega3) at the returns of
  beta to beta(0) mod 2 pi obey z_{k+1} = M z_k with M the monodromy matrix of (62) (or its
  inverse when beta falls). M is estimated from the z_k (least squares); |tr M| < 2 gives the
  rotation number nu = arccos(tr M / 2) / (2 pi) of z per revolution. If z_q returns to z_0 to
  within ``return_tol`` (default RETURN_TOL_FACTOR rtol, relative) for some q up to the number
  of revolutions observed, nu is rational with denominator q (within resolution) and the
  solution is periodic with period the time of q revolutions; otherwise it is quasi-periodic
  with irrational nu (within resolution: no denominator up to the revolutions observed).
  |tr M| >= 2 (the unstable region of Fig. 9, the standard ball) means growing (omega2, omega3);
  by Prop. 8 omega1 must turn later: undetermined within t_max.

alpha, the angle round the rim, is not part of the phase space: a periodic solution carries
the ball round the rim by ``alpha_advance`` per period, and the ball's motion in space closes
only if that is a rational multiple of 2 pi. This is reported, it does not change the type.
"""

from __future__ import annotations

import numpy as np

from rimroll.solver._arguments import positive_number, real_array, real_number, tolerances
from rimroll.solver._jit import vectorised
from rimroll.solver.analysis import reduced, trajectory
from rimroll.solver.engine import rules
from rimroll.solver.engine.outcomes import code_table
from rimroll.solver.physics import kinematics, rolling
from rimroll.solver.physics.params import Params
from rimroll.solver.physics.steady_motion import check_params

TYPES = code_table("""
undetermined: none of the types below resolved within t_max (slow orbit, failed integration)
trivial_equilibrium: cos(beta) = 0, omega1 = omega3 = 0 (46), ball on top or hanging
nontrivial_equilibrium: steady motion (47), omega1 = 0, omega2 = omega20(beta, omega3) (48)
trivial_connection: tends to the unstable ball-on-top equilibrium x0+ (46) at its rate sqrt(g/(rho (1+j)));
    homoclinic or heteroclinic
nontrivial_connection: tends to a saddle steady motion (47) at the rate sqrt(h) of (54); homoclinic or heteroclinic
non_periodic_pendulum: omega2 = omega3 = 0 and E > m g rho, omega1 keeps its sign (Prop. 6)
periodic: two transversal zeros of omega1, period 2 (t2 - t1) (Prop. 4), or a rotation of beta with a rational
    rotation number
quasi_periodic: omega1 keeps its sign, (omega2, omega3) turn by an irrational fraction of a turn per revolution of
    beta (Props. 5, 7)
""")
TYPE_MEANINGS, TYPE_FLAG_VALUES, TYPE_FLAG_MEANINGS = TYPES
(UNDETERMINED, TRIVIAL_EQUILIBRIUM, NONTRIVIAL_EQUILIBRIUM, TRIVIAL_CONNECTION, NONTRIVIAL_CONNECTION,
 NON_PERIODIC_PENDULUM, PERIODIC, QUASI_PERIODIC) = TYPE_FLAG_VALUES

CONNECTIONS = code_table("""
not_a_connection: types other than 3 and 4
homoclinic: the orbit crosses omega1 = 0 transversally, so by (61) both ends are the same equilibrium (or the
    backward end is found to be it)
heteroclinic: the backward solution tends to another equilibrium
other_end_unresolved: the backward solution neither crosses omega1 = 0 nor reaches an equilibrium within t_max
""")
CONNECTION_MEANINGS, CONNECTION_FLAG_VALUES, CONNECTION_FLAG_MEANINGS = CONNECTIONS
NOT_A_CONNECTION, HOMOCLINIC, HETEROCLINIC, OTHER_END_UNRESOLVED = CONNECTION_FLAG_VALUES

DEFAULT_T_MAX = 20.0
DEFAULT_EQ_TOL = 1e-9
CONNECTION_TOL_FACTOR = 10.0
"""Default connection_tol = this times sqrt(rtol) (scaled distance of closest approach)."""
WINDOW_TOP = 1e-2
"""Largest scaled distance to the saddle at which its linearisation sets the rate (fit window top)."""
RATE_TOL = 0.02
"""Largest relative difference between the measured approach rate and the saddle's eigenvalue."""
SAMPLES_PER_STEP = 8
"""Dense-output points per integration step at which the distance to an equilibrium is looked at."""
MIN_REVOLUTIONS = 3
"""Revolutions of beta needed to estimate the monodromy matrix and check it on one more."""
RETURN_TOL_FACTOR = 1e4
"""Default return_tol = this times rtol (relative distance of z_q from z_0 that counts as a return)."""
LINEAR_MAP_TOL_FACTOR = 1e4
"""The returns must obey one linear map z_{k+1} = M z_k to within this times rtol (relative)."""

_energy = vectorised(rolling.energy)
_omega_scale = vectorised(rules.omega_scale)
_steady_residual = vectorised(rules.steady_residual)
_alpha_rate = vectorised(kinematics.alpha_rate)
_GAUSS_NODES, _GAUSS_WEIGHTS = np.polynomial.legendre.leggauss(8)


def _check(states, p: Params):
    """``states`` as a float array (..., 4) of real numbers, ``p`` a conservative Params. A state with
    NaN or inf is not refused: a map over many states marks it undetermined (``classify``)."""
    check_params(p)
    states = real_array("states", states)
    if states.shape[-1:] != (4,):
        raise ValueError(f"states must have shape (..., 4) = (beta, omega1, omega2, omega3); got {states.shape}")
    if p.dissipative:
        raise ValueError(f"Theorem 1 is about the conservative rolling equations: need k_r = k_d = 0; "
                         f"got k_r={p.k_r}, k_d={p.k_d}")
    return states


def _checked_eq_tol(eq_tol) -> float:
    v = real_number("eq_tol", eq_tol, allowed="a relative tolerance, 0 <= eq_tol < 1")
    if not 0.0 <= v < 1.0:
        raise ValueError(f"`eq_tol` must be a relative tolerance, 0 <= eq_tol < 1; got {eq_tol!r}")
    return v


def _checked_tolerances(t_max, rtol, atol, connection_tol, return_tol):
    """The checks of :func:`classify` of its time and tolerances (ValueError naming the argument)."""
    positive_number("t_max", t_max)
    tolerances(rtol, atol)  # as for solver.simulate
    for name, value in (("connection_tol", connection_tol), ("return_tol", return_tol)):
        if value is not None:
            positive_number(name, value)


def equilibrium_kind(states, p: Params, eq_tol: float = DEFAULT_EQ_TOL):
    """Code per state: TRIVIAL_EQUILIBRIUM, NONTRIVIAL_EQUILIBRIUM, or -1 (not an equilibrium) (int8).

    states: (..., 4) of (beta [rad], omega1, omega2, omega3 [1/s]); p: conservative Params.
    An equilibrium has ``rules.steady_residual`` <= eq_tol (omega1 and every rate vanish
    relative to their scales; 0 <= eq_tol < 1); a trivial one also has |omega3| <= eq_tol S.
    """
    states = _check(states, p)
    eq_tol = _checked_eq_tol(eq_tol)
    beta, w1, w2, w3 = np.moveaxis(states, -1, 0)
    pa = p.as_array()
    eq = _steady_residual(beta, w1, w2, w3, pa) <= eq_tol
    trivial = eq & (np.abs(w3) <= eq_tol * _omega_scale(w1, w2, w3, pa))
    out = np.full(states.shape[:-1], -1, dtype=np.int8)
    out[eq] = NONTRIVIAL_EQUILIBRIUM
    out[trivial] = TRIVIAL_EQUILIBRIUM
    return out


# ------------------------------------------------------------------------------ evidence per state
_FIELDS = {"type": UNDETERMINED, "half_period": np.nan, "period": np.nan, "t_first_zero": np.nan,
           "alpha_advance": np.nan, "rotation_number": np.nan, "revolutions": np.nan,
           "beta_eq": np.nan, "omega2_eq": np.nan, "omega3_eq": np.nan, "saddle_rate": np.nan,
           "approach_rate": np.nan, "connection": NOT_A_CONNECTION}
_INT_FIELDS = ("type", "connection")


def _samples(found: trajectory.Scan, t_end: float):
    """(times, states (n, 4)) on the dense output, SAMPLES_PER_STEP per integration step up to t_end."""
    ts = np.asarray(found.sol.ts, dtype=float)
    ts = ts[ts <= t_end]
    if ts[-1] < t_end:
        ts = np.append(ts, t_end)
    frac = np.arange(SAMPLES_PER_STEP) / SAMPLES_PER_STEP
    t = np.append((ts[:-1, None] + frac * np.diff(ts)[:, None]).ravel(), t_end)
    return t, found.sol(t).T


def _scaled_distance(x, x_eq, p: Params):
    """max(|beta - beta*|, |omega - omega*| / S(x*)) per row of x (..., 4)."""
    s = float(_omega_scale(*x_eq[1:], p.as_array()))
    d = np.abs(x - x_eq)
    return np.maximum(d[..., 0], d[..., 1:].max(axis=-1) / s)


def _approach(found: trajectory.Scan, x0, p: Params, connection_tol: float):
    """The saddle the scanned solution tends to, or None.

    Returns (x*, lambda from the paper's eigenvalue, measured rate, time of closest approach)
    when the solution comes within connection_tol of a saddle of its level and approaches it at
    the saddle's rate (module docstring).
    """
    t, x = _samples(found, found.t_end)
    pa = p.as_array()
    residual = _steady_residual(x[:, 0], x[:, 1], x[:, 2], x[:, 3], pa)
    k = int(np.argmin(residual))
    if not residual[k] <= WINDOW_TOP:
        return None
    x_eq = reduced.equilibrium(reduced.level(x0, p), x[k, 0], p)
    if not np.all(np.isfinite(x_eq)):
        return None
    lam = reduced.saddle_rate(x_eq, p)
    if not np.isfinite(lam):
        return None  # a centre (or x0-): nearby solutions circle it, they do not tend to it
    d = _scaled_distance(x, x_eq, p)
    k = int(np.argmin(d))
    d_min = float(d[k])
    if not d_min <= connection_tol:
        return None
    # the approach: from the last time before t_k at which d >= WINDOW_TOP (or t = 0) to t_k
    above = np.nonzero(d[:k] >= WINDOW_TOP)[0]
    start = int(above[-1]) + 1 if above.size else 0
    window = np.arange(start, k + 1)
    window = window[(d[window] <= WINDOW_TOP) & (d[window] >= 10.0 * d_min)]
    if window.size < 8 or np.log10(d[window].max() / d[window].min()) < 1.0:
        return None
    slope = np.polyfit(t[window], np.log(d[window]), 1)[0]
    rate = -float(slope)
    if not abs(rate / lam - 1.0) <= RATE_TOL:
        return None
    return x_eq, lam, rate, float(t[k])


def _same_equilibrium(a, b, p: Params, tol: float) -> bool:
    """Whether two equilibria are the same state, beta compared modulo 2 pi."""
    shift = 2 * np.pi * np.round((b[0] - a[0]) / (2 * np.pi))
    return bool(_scaled_distance(b - np.array([shift, 0, 0, 0]), a, p) <= tol)


def _transversal(states, p: Params, rtol: float):
    pa = p.as_array()
    return np.array([bool(rules.transversal_omega1_zero(*x, pa, rtol)) for x in states], dtype=bool)


def _far_transversal_zero(times, states, before: float, x_eq, p: Params, rtol: float) -> bool:
    """A transversal omega1 zero before ``before`` away from the saddle (not the round-off's)."""
    sel = times < before
    if not np.any(sel):
        return False
    far = _scaled_distance(states[sel], x_eq, p) > WINDOW_TOP
    return bool(np.any(far & _transversal(states[sel], p, rtol)))


def _connection_kind(x0, x_eq, t_c, found, p, t_max, rtol, atol, connection_tol):
    """HOMOCLINIC / HETEROCLINIC / OTHER_END_UNRESOLVED for a solution tending to the saddle x_eq."""
    starts_on_plane = x0[1] == 0.0 and _scaled_distance(x0, x_eq, p) > WINDOW_TOP
    if starts_on_plane or _far_transversal_zero(found.zero_times, found.zero_states, t_c, x_eq, p, rtol):
        return HOMOCLINIC
    mirror = np.array([x0[0], -x0[1], x0[2], x0[3]])  # backward time, by (61)
    back = trajectory.scan(mirror, p, t_max, n_zeros=2, rtol=rtol, atol=atol)
    other = _approach(back, mirror, p, connection_tol)
    t_other = other[3] if other is not None else back.t_end
    if _far_transversal_zero(back.zero_times, back.zero_states, t_other, x_eq, p, rtol):
        return HOMOCLINIC
    if other is None:
        return OTHER_END_UNRESOLVED
    return HOMOCLINIC if _same_equilibrium(x_eq, other[0], p, connection_tol) else HETEROCLINIC


def _alpha_advance(found: trajectory.Scan, t_a: float, t_b: float, p: Params) -> float:
    """Integral of alpha_dot (19) (u1 = 0) over [t_a, t_b] on the dense output [rad] (Gauss-Legendre per step)."""
    ts = np.asarray(found.sol.ts, dtype=float)
    edges = np.unique(np.concatenate([[t_a, t_b], ts[(ts > t_a) & (ts < t_b)]]))
    mid, half = 0.5 * (edges[1:] + edges[:-1]), 0.5 * np.diff(edges)
    nodes = (mid[:, None] + half[:, None] * _GAUSS_NODES).ravel()
    x = found.sol(nodes)
    rate = _alpha_rate(x[0], x[3], 0.0, p.as_array()).reshape(mid.size, -1)
    return float(np.sum(half * (rate @ _GAUSS_WEIGHTS)))


def _rotation(found: trajectory.Scan, x0, p: Params, rtol: float, return_tol: float):
    """(code, rotation number, revolutions, period) of a solution whose omega1 keeps its sign, or None."""
    n = found.return_times.size
    if n < MIN_REVOLUTIONS:
        return None
    z = np.vstack([x0[2:], found.return_states[:, 2:]])
    size = float(np.abs(z).max())
    monodromy = np.linalg.lstsq(z[:-1], z[1:], rcond=None)[0].T  # z_{k+1} = M z_k
    if np.abs(z[1:] - z[:-1] @ monodromy.T).max() > LINEAR_MAP_TOL_FACTOR * rtol * size:
        return None  # not one linear map: (62) does not hold along it (cannot happen while omega1 keeps its sign)
    trace = float(np.trace(monodromy))
    if not abs(trace) < 2.0:
        return None  # growing (omega2, omega3), region U of Fig. 9: omega1 turns later (Prop. 8)
    nu = float(np.arccos(trace / 2.0) / (2 * np.pi))
    back = np.abs(z[1:] - z[0]).max(axis=1) <= return_tol * size
    if np.any(back):
        q = int(np.argmax(back)) + 1
        return PERIODIC, nu, n, float(found.return_times[q - 1])
    return QUASI_PERIODIC, nu, n, np.nan


def _classify_one(x0, p: Params, t_max, rtol, atol, connection_tol, return_tol):
    """Evidence dict (keys of _FIELDS) of one state that is not an equilibrium nor in the pendulum plane."""
    out = {}
    found = trajectory.scan(x0, p, t_max, n_zeros=2, rtol=rtol, atol=atol)
    times, states = found.zero_times, found.zero_states
    starts_on_plane = x0[1] == 0.0  # then t = 0 is a transversal zero (not an equilibrium)
    transversal = _transversal(states, p, rtol)
    if starts_on_plane:
        times, transversal = np.concatenate([[0.0], times]), np.concatenate([[True], transversal])
    saddle = _approach(found, x0, p, connection_tol)
    if saddle is not None:
        x_eq, lam, rate, t_c = saddle
        # the zeros near and after the closest approach are the round-off's departure from the saddle
        real = (times < t_c) & ((times == 0.0) | (_scaled_distance(found.sol(times).T, x_eq, p) > WINDOW_TOP))
        if np.any(real):
            out["t_first_zero"] = times[real][0]
        out.update(type=TRIVIAL_CONNECTION if reduced.is_trivial(x_eq, p) else NONTRIVIAL_CONNECTION,
                   beta_eq=(x_eq[0] + np.pi) % (2 * np.pi) - np.pi, omega2_eq=x_eq[2], omega3_eq=x_eq[3],
                   saddle_rate=lam, approach_rate=rate,
                   connection=_connection_kind(x0, x_eq, t_c, found, p, t_max, rtol, atol, connection_tol))
        return out
    if times.size:
        out["t_first_zero"] = times[0]
    if times.size >= 2 and transversal[0] and transversal[1]:
        out.update(type=PERIODIC, half_period=times[1] - times[0], period=2 * (times[1] - times[0]),
                   alpha_advance=2 * _alpha_advance(found, times[0], times[1], p))
        return out
    if times.size == 0 and found.status == 0:
        rot = _rotation(found, x0, p, rtol, return_tol)
        if rot is not None:
            code, nu, n, period = rot
            out.update(type=code, rotation_number=nu, revolutions=n, period=period)
            if code == PERIODIC:
                out["alpha_advance"] = _alpha_advance(found, 0.0, period, p)
    return out


def classify(states, p: Params, t_max: float = DEFAULT_T_MAX, rtol: float = trajectory.DEFAULT_RTOL,
             atol: float = trajectory.DEFAULT_ATOL, eq_tol: float = DEFAULT_EQ_TOL,
             connection_tol: float | None = None, return_tol: float | None = None):
    """Type of each rolling state (Theorem 1) with the evidence.

    states: (..., 4) of (beta [rad], omega1, omega2, omega3 [1/s]); p: conservative Params
    (k_r = k_d = 0; mu ignored). t_max [s]: how long to follow each solution (finite, > 0);
    rtol [1], atol [units of each component]: DOP853 tolerances (1e-14 <= rtol <= 1e-2 and
    0 < atol <= 1, as for ``solver.simulate``; scipy raises an rtol below 100 eps to 100 eps, with a
    warning); eq_tol [1]: relative tolerance of the equilibrium and pendulum tests
    (0 <= eq_tol < 1); connection_tol [1]: scaled distance of closest approach to a saddle (> 0;
    default CONNECTION_TOL_FACTOR sqrt(rtol)); return_tol [1]: relative distance of a return of
    (omega2, omega3) after q revolutions (> 0; default RETURN_TOL_FACTOR rtol). A bad argument
    raises ValueError naming it, TypeError for a ``p`` that is not a :class:`Params`; a state with
    NaN or inf is UNDETERMINED (type 0), so that a map over many states goes on. Returns, each of
    shape states.shape[:-1]:

    - "type": int8 codes (module docstring);
    - "half_period" [s]: t2 - t1 between two transversal zeros of omega1 (Prop. 4), else NaN;
    - "period" [s]: 2 half_period, or for a rotation with rational rotation number the time of
      q revolutions; NaN unless periodic;
    - "t_first_zero" [s]: first zero of omega1 in [0, t_max] (NaN if none was found or not integrated);
    - "alpha_advance" [rad]: the angle round the rim travelled in one period (periodic only);
    - "rotation_number" [1]: turn of (omega2, omega3) per revolution of beta, in [0, 1/2]
      (rotations of types 6 and 7), and "revolutions": how many revolutions were observed (the
      largest denominator the rational test could see);
    - "beta_eq" [rad, in [-pi, pi)], "omega2_eq", "omega3_eq" [1/s]: the equilibrium a connection tends to;
      "saddle_rate" [1/s]: its eigenvalue lambda, "approach_rate" [1/s]: the rate measured;
    - "connection": int8 CONNECTION_* codes (homoclinic, heteroclinic, other end unresolved).
    """
    states = _check(states, p)
    _checked_tolerances(t_max, rtol, atol, connection_tol, return_tol)
    if connection_tol is None:
        connection_tol = CONNECTION_TOL_FACTOR * np.sqrt(rtol)
    if return_tol is None:
        return_tol = RETURN_TOL_FACTOR * rtol
    shape = states.shape[:-1]
    flat = states.reshape(-1, 4)
    n = flat.shape[0]
    res = {k: np.full(n, v, dtype=np.int8 if k in _INT_FIELDS else float) for k, v in _FIELDS.items()}

    eq = equilibrium_kind(flat, p, eq_tol)
    beta, w1, w2, w3 = flat.T
    pa = p.as_array()
    s_omega = _omega_scale(w1, w2, w3, pa)
    E = _energy(beta, w1, w2, w3, pa)
    e_top = p.m * p.g * p.rho  # energy of the ball resting on top of the rim (x0+ with omega2 = 0)
    pendulum = (np.abs(w2) <= eq_tol * s_omega) & (np.abs(w3) <= eq_tol * s_omega)
    rotating = pendulum & (E > e_top * (1.0 + eq_tol))
    separatrix = pendulum & (np.abs(E - e_top) <= eq_tol * e_top)

    finite = np.all(np.isfinite(flat), axis=-1)
    for i in range(n):
        if not finite[i]:  # a NaN or inf state: UNDETERMINED (no test below applies), the other states go on
            continue
        if eq[i] >= 0:
            res["type"][i] = eq[i]
            res["t_first_zero"][i] = 0.0  # omega1 = 0 throughout
            continue
        if rotating[i]:
            res["type"][i] = NON_PERIODIC_PENDULUM
            continue
        evidence = _classify_one(flat[i], p, t_max, rtol, atol, connection_tol, return_tol)
        if separatrix[i] and evidence.get("type") != TRIVIAL_CONNECTION:
            # Prop. 6: E = m g rho in the pendulum plane is the separatrix of x0+, whatever t_max shows
            top = np.array([np.pi / 2, 0.0, 0.0, 0.0])
            evidence = dict(type=TRIVIAL_CONNECTION, beta_eq=top[0], omega2_eq=0.0, omega3_eq=0.0,
                            saddle_rate=reduced.saddle_rate(top, p), connection=HOMOCLINIC,
                            t_first_zero=evidence.get("t_first_zero", np.nan))
        for k, v in evidence.items():
            res[k][i] = v
    return {k: v.reshape(shape) for k, v in res.items()}


def solution_type(states, p: Params, t_max: float = DEFAULT_T_MAX, rtol: float = trajectory.DEFAULT_RTOL,
                  atol: float = trajectory.DEFAULT_ATOL, eq_tol: float = DEFAULT_EQ_TOL):
    """Type code (int8, :data:`TYPE_MEANINGS`) of each rolling state: ``classify(...)["type"]``.

    states: (..., 4) of (beta [rad], omega1, omega2, omega3 [1/s]) (a non-finite one: 0, undetermined);
    p: a conservative :class:`Params`; t_max [s]: how long to follow each solution (finite, > 0); rtol, atol, eq_tol:
    the tolerances of :func:`classify`, checked there (ValueError naming a bad one). Returns an
    int8 array of shape states.shape[:-1].
    """
    return classify(states, p, t_max=t_max, rtol=rtol, atol=atol, eq_tol=eq_tol)["type"]
