"""Types of the solutions of the rolling ball (paper Sect. 4.4, Theorem 1, Table 2).

The classification is about the conservative rolling equations (33)-(36) as a mathematical
system: falling (F2 < 0) and slipping are NOT considered (paper Sect. 4), so it integrates
:func:`solver.rolling.rolling_rhs` itself (``solver.trajectory``) instead of ``solver.simulate``,
which stops at a fall.

Codes (int8; CF ``flag_values`` / ``flag_meanings`` in files):

0 trivial_equilibrium       f(x) = 0 with cos(beta) = 0, omega1 = omega3 = 0 (46); any omega2
1 nontrivial_equilibrium    f(x) = 0 with omega1 = 0, omega3 != 0, omega2 = omega20(beta, omega3) (47)-(48)
2 periodic                  omega1 has two transversal zeros within t_max: periodic with period
                            2 (t2 - t1) (Prop. 4); ``half_period`` = t2 - t1
3 non_periodic_pendulum     omega2 = omega3 = 0 and E > m g rho (Prop. 6; the paper prints m g r,
                            the conserved energy has m g rho, docs/outcome-studies.md): omega1 never changes sign
4 undetermined              none of the above within t_max: a connection of unstable equilibria
                            (homoclinic/heteroclinic), a quasi-periodic solution (stable region of
                            Fig. 9 only), the separatrix E = m g rho of the pendulum, a slow
                            periodic orbit, or a failed integration

"Within a tolerance" (``eq_tol``, relative) uses the scales of ``solver.rules`` (the one
definition shared with the outcome engine): an equilibrium has ``rules.steady_residual`` <=
eq_tol, a trivial one also |omega3| <= eq_tol S with S = ``rules.omega_scale``; the pendulum
tests compare omega2, omega3 with eq_tol S. A zero of omega1 is transversal by
``rules.transversal_omega1_zero`` at the integration's rtol.
"""

from __future__ import annotations

import numpy as np

from solver import rolling, rules, trajectory
from solver._jit import vectorised
from solver.params import Params

TRIVIAL_EQUILIBRIUM = 0
NONTRIVIAL_EQUILIBRIUM = 1
PERIODIC = 2
NON_PERIODIC_PENDULUM = 3
UNDETERMINED = 4

TYPE_MEANINGS = {
    TRIVIAL_EQUILIBRIUM: "trivial_equilibrium: cos(beta) = 0, omega1 = omega3 = 0 (46), ball on top or hanging",
    NONTRIVIAL_EQUILIBRIUM: "nontrivial_equilibrium: steady motion (47), omega1 = 0, omega2 = omega20(beta, omega3) (48)",
    PERIODIC: "periodic: two transversal zeros of omega1, period 2 (t2 - t1) (Prop. 4)",
    NON_PERIODIC_PENDULUM: "non_periodic_pendulum: omega2 = omega3 = 0 and E > m g rho, omega1 keeps its sign (Prop. 6)",
    UNDETERMINED: "undetermined: none of the above within t_max (connection, quasi-periodic, separatrix or slow orbit)",
}
TYPE_FLAG_VALUES = tuple(TYPE_MEANINGS)
TYPE_FLAG_MEANINGS = " ".join(m.split(":")[0] for m in TYPE_MEANINGS.values())

DEFAULT_T_MAX = 20.0
DEFAULT_EQ_TOL = 1e-9

_energy = vectorised(rolling.energy)
_omega_scale = vectorised(rules.omega_scale)
_steady_residual = vectorised(rules.steady_residual)


def _check(states, p: Params):
    states = np.asarray(states, dtype=float)
    if states.shape[-1:] != (4,):
        raise ValueError(f"states must have shape (..., 4) = (beta, omega1, omega2, omega3); got {states.shape}")
    if p.dissipative:
        raise ValueError(f"Theorem 1 is about the conservative rolling equations: need k_r = k_d = 0; "
                         f"got k_r={p.k_r}, k_d={p.k_d}")
    return states


def equilibrium_kind(states, p: Params, eq_tol: float = DEFAULT_EQ_TOL):
    """Code per state: TRIVIAL_EQUILIBRIUM, NONTRIVIAL_EQUILIBRIUM, or -1 (not an equilibrium) (int8).

    An equilibrium has ``rules.steady_residual`` <= eq_tol (omega1 and every rate vanish
    relative to their scales); a trivial one also has |omega3| <= eq_tol S.
    """
    states = _check(states, p)
    beta, w1, w2, w3 = np.moveaxis(states, -1, 0)
    pa = p.as_array()
    eq = _steady_residual(beta, w1, w2, w3, pa) <= eq_tol
    trivial = eq & (np.abs(w3) <= eq_tol * _omega_scale(w1, w2, w3, pa))
    out = np.full(states.shape[:-1], -1, dtype=np.int8)
    out[eq] = NONTRIVIAL_EQUILIBRIUM
    out[trivial] = TRIVIAL_EQUILIBRIUM
    return out


def classify(states, p: Params, t_max: float = DEFAULT_T_MAX, rtol: float = trajectory.DEFAULT_RTOL,
             atol: float = trajectory.DEFAULT_ATOL, eq_tol: float = DEFAULT_EQ_TOL):
    """Type of each rolling state (Theorem 1) with the evidence.

    states: (..., 4) of (beta [rad], omega1, omega2, omega3 [1/s]); p: conservative Params
    (k_r = k_d = 0; mu ignored). t_max [s]: how long to look for two zeros of omega1; rtol, atol:
    DOP853 tolerances. Returns {"type": int8 codes (module docstring), "half_period": t2 - t1 [s]
    (NaN unless periodic), "t_first_zero": first zero of omega1 in [0, t_max] [s] (NaN if none
    was found or not integrated)}, each of shape states.shape[:-1].
    """
    states = _check(states, p)
    shape = states.shape[:-1]
    flat = states.reshape(-1, 4)
    kind = np.full(flat.shape[0], UNDETERMINED, dtype=np.int8)
    half = np.full(flat.shape[0], np.nan)
    first = np.full(flat.shape[0], np.nan)

    eq = equilibrium_kind(flat, p, eq_tol)
    beta, w1, w2, w3 = flat.T
    pa = p.as_array()
    s_omega = _omega_scale(w1, w2, w3, pa)
    E = _energy(beta, w1, w2, w3, p.as_array())
    e_top = p.m * p.g * p.rho  # energy of the ball resting on top of the rim (x0+ with omega2 = 0)
    pendulum = (np.abs(w2) <= eq_tol * s_omega) & (np.abs(w3) <= eq_tol * s_omega)
    rotating = pendulum & (E > e_top * (1.0 + eq_tol))
    separatrix = pendulum & (np.abs(E - e_top) <= eq_tol * e_top)

    for i in range(flat.shape[0]):
        if eq[i] >= 0:
            kind[i] = eq[i]
            first[i] = 0.0  # omega1 = 0 throughout
            continue
        if rotating[i]:
            kind[i] = NON_PERIODIC_PENDULUM
            continue
        if separatrix[i]:
            continue  # connection of the trivial equilibria: omega1 -> 0 only as t -> inf
        if not np.all(np.isfinite(flat[i])):
            continue
        starts_on_plane = w1[i] == 0.0  # then t = 0 is a transversal zero (not an equilibrium)
        need = 1 if starts_on_plane else 2
        times, _, status, at = trajectory.omega1_zeros(flat[i], p, t_max, n_zeros=need, rtol=rtol, atol=atol,
                                                       with_states=True)
        transversal = np.array([bool(rules.transversal_omega1_zero(*x, pa, rtol)) for x in at], dtype=bool)
        if starts_on_plane:
            times, transversal = np.concatenate([[0.0], times]), np.concatenate([[True], transversal])
        if times.size:
            first[i] = times[0]
        if times.size >= 2 and transversal[0] and transversal[1]:
            kind[i] = PERIODIC
            half[i] = times[1] - times[0]
    return {"type": kind.reshape(shape), "half_period": half.reshape(shape), "t_first_zero": first.reshape(shape)}


def solution_type(states, p: Params, t_max: float = DEFAULT_T_MAX, rtol: float = trajectory.DEFAULT_RTOL,
                  atol: float = trajectory.DEFAULT_ATOL, eq_tol: float = DEFAULT_EQ_TOL):
    """Type code (int8, :data:`TYPE_MEANINGS`) of each rolling state; see :func:`classify`."""
    return classify(states, p, t_max=t_max, rtol=rtol, atol=atol, eq_tol=eq_tol)["type"]
