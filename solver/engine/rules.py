"""The simulation rules of the outcome engine, written once (docs/outcome-engine.md).

Every implementation of the rules — the compiled engine (``solver.engine.kernels``), the scipy
reference (``solver.analysis.scipy_reference``) and the solution types of Theorem 1
(``solver.analysis.solution_types``) — calls these functions; only the integration and the event
location differ between them. All functions are compiled scalar kernels that take a flat
parameter vector ``p`` (:meth:`solver.Params.as_array`); ``.py_func`` is the plain-Python
version, which broadcasts over numpy arrays.

Scales (what "small" means for a state x = (beta, omega1, omega2, omega3)):

* ``omega_scale`` = max(|omega1|, |omega2|, |omega3|, sqrt(g/rho)) [1/s]: the size of the
  angular velocities (sqrt(g/rho) is the pendulum rate of the ball on the rim);
* ``rate_scale`` = the sum of the magnitudes of the terms of omega1_dot (33)/(83), gravity's
  at its largest g/(r(1+j)) [1/s^2]: what omega1_dot is a difference of, so
  |omega1_dot| / rate_scale is its relative size.

Rules:

* **Steady motion** (:func:`on_steady_motion`): a state whose rates all vanish, relative to
  those scales, to within STEADY_TOL (whatever rtol). Such a state is an equilibrium of (33)-(36) (a steady motion
  (47)-(48), or the
  trivial one (46) on top of the rim): in exact arithmetic it never moves, and an integration
  at tolerance rtol cannot tell it from a periodic orbit of relative amplitude ~rtol around it,
  nor follow a departure from an unstable one that starts at round-off. The engine reports it
  as the outcome ``steady_motion`` at t = 0 (with h of (54): stable if h < 0), whatever t_max,
  rtol and method. STEADY_TOL is fixed, not scaled with rtol, so the answer is the same for
  every rtol; it is 1e-7 because a state moved by 1e-9 from a steady motion near the singular
  line beta0 = pi/2 already has a residual ~1e-8. An orbit of smaller relative amplitude is
  physically the steady motion; one of larger amplitude is integrated (and its omega1 zeros
  count if the integration resolves them: below).
* **Transversal omega1 zero** (:func:`transversal_omega1_zero`): a zero of omega1 counts as a
  crossing of the plane omega1 = 0 (Prop. 4) only if |omega1_dot| there exceeds
  TRANSVERSAL_RTOL_FACTOR * rtol * rate_scale: a slope that the integration at tolerance rtol
  resolves. Zeros with a smaller slope are touching zeros or round-off.
* **Phase start** (:func:`phase_start_action`): F2 < 0 -> the ball separates now (free flight);
  rolling outside the friction cone (39) (finite mu) -> slipping starts now; a rolling state on
  a steady motion at t = 0 -> ``steady_motion``; otherwise the phase runs.
* **Free flight** (:func:`fall_outcome`): ``solver.physics.flight.lands_inside`` from the state at
  separation (with the slip velocity if slipping).
"""

from __future__ import annotations

import numpy as np

from rimroll.solver._compile import engine_kernel
from rimroll.solver.engine.outcomes import FALL_IN, FALL_OUT
from rimroll.solver.physics import loads, rolling
from rimroll.solver.physics.constants import constants
from rimroll.solver.physics.flight import lands_inside
from rimroll.solver.physics.params import P_G, P_RHO

STEADY_TOL = 1e-7
"""Largest relative residual of the rates (``steady_residual``) of a state on a steady motion."""
TRANSVERSAL_RTOL_FACTOR = 1.0
"""An omega1 zero is a crossing if |omega1_dot| > this many rtol times the rate scale."""

# Actions at the start of a phase (phase_start_action).
RUN = 0
FALL = 1
SLIP = 2
STEADY = 3


@engine_kernel(runtime=True)
def omega_scale(omega1, omega2, omega3, p):
    """max(|omega1|, |omega2|, |omega3|, sqrt(g/rho)) [1/s]: the size of the angular velocities."""
    return np.maximum(np.maximum(np.abs(omega1), np.abs(omega2)),
                      np.maximum(np.abs(omega3), np.sqrt(p[P_G] / p[P_RHO])))


@engine_kernel(runtime=True)
def rate_scale(beta, omega1, omega2, omega3, p, load=None):
    """Size of the terms of omega1_dot (33) with dissipation (83) and an external ``load`` [1/s^2].

    The sum of their magnitudes, with the gravity term taken at its largest, g / (r (1+j)), so
    that the scale does not vanish where cos(beta) = 0 (the trivial equilibrium (46)).
    """
    r, R, rho, m, j, g, mu, k_r, k_d = constants(p)
    c = np.cos(beta)
    D = R - rho * c
    scale = (np.abs(r * omega3 * omega3 * np.sin(beta) / D) + np.abs(j * r * omega2 * omega3 * c / ((1.0 + j) * D))
             + g / (r * (1.0 + j)) + np.abs(k_r * omega1))
    if load is not None:
        scale = scale + np.abs(loads.rolling_rates(load, p)[0])
    return scale


@engine_kernel(runtime=True)
def steady_residual(beta, omega1, omega2, omega3, p, load=None):
    """Relative size of the rates of the rolling state (dimensionless); 0 on an equilibrium.

    max(|omega1| / S, |omega1_dot| / rate_scale, |omega2_dot| / S^2, |omega3_dot| / S^2) with
    S = omega_scale: beta_dot = (r/rho) omega1, and without dissipation omega2_dot and
    omega3_dot are proportional to omega1 too; with dissipation they hold -k_d omega2 and
    -k_r omega3, which vanish only with the spin.
    """
    s = omega_scale(omega1, omega2, omega3, p)
    _, d1, d2, d3 = rolling.rolling_rhs(beta, omega1, omega2, omega3, p, load)
    return np.maximum(np.maximum(np.abs(omega1) / s, np.abs(d1) / rate_scale(beta, omega1, omega2, omega3, p, load)),
                      np.maximum(np.abs(d2) / (s * s), np.abs(d3) / (s * s)))


@engine_kernel(runtime=True)
def on_steady_motion(beta, omega1, omega2, omega3, p, load=None):
    """Whether the rolling state is an equilibrium of (33)-(36)/(83) (and an external ``load``) to
    within STEADY_TOL."""
    return steady_residual(beta, omega1, omega2, omega3, p, load) <= STEADY_TOL


@engine_kernel(runtime=True)
def transversal_omega1_zero(beta, omega1, omega2, omega3, p, rtol, load=None):
    """Whether an omega1 zero at this rolling state crosses transversally at tolerance rtol (with an
    external ``load``, if any)."""
    _, d1, _, _ = rolling.rolling_rhs(beta, omega1, omega2, omega3, p, load)
    return np.abs(d1) > TRANSVERSAL_RTOL_FACTOR * rtol * rate_scale(beta, omega1, omega2, omega3, p, load)


@engine_kernel(runtime=True)
def phase_start_action(rolling_phase, hybrid, first, f2, friction_margin, steady):
    """What happens at the start of a phase, in the rules' order.

    rolling_phase: the phase is rolling; hybrid: finite mu; first: t = 0 (the initial state);
    f2 [N]: the normal force; friction_margin [N]: (39) (ignored unless hybrid and rolling);
    steady: the state is on a steady motion (ignored unless rolling and first).
    Returns FALL, SLIP, STEADY or RUN.
    """
    if f2 < 0.0:
        return FALL
    if hybrid and rolling_phase and friction_margin < 0.0:
        return SLIP
    if rolling_phase and first and steady:
        return STEADY
    return RUN


@engine_kernel(runtime=True)
def fall_outcome(beta, omega1, omega3, u1, u3, p):
    """FALL_IN or FALL_OUT by free flight from the separation state (u1 = u3 = 0 when rolling)."""
    if lands_inside(beta, omega1, omega3, u1, u3, p):
        return FALL_IN
    return FALL_OUT
