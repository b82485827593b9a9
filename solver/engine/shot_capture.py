"""Capture of a shot onto the rim and its hand-off to the rim engine (``simulate``).

Rule (docs/shots.md): at a rim impact whose rebound speed e_rim |v_n| would be below v_cap, the
impact is plastic instead (e = 0: the normal speed is removed) and its friction brings the contact
point to rest (a full stick, P_t = -m u_t / (1 + 1/j)). If the Coulomb impact (|P_t| <= mu_rim P_n)
would have left a slip, that slip speed is recorded as ``slip_cap`` (> 0: a sliding capture, the
stick then needs more than mu_rim P_n; the engine starts from rolling states only). The ball stays on
the rim if the rolling normal force F2 of (31) is >= 0 there; its paper state (beta, omega1, omega2,
omega3), rolling, goes to ``simulate`` for the time left. When the engine says the ball left the rim
(fall_in, fall_out), the 3-D state at the separation is rebuilt from its end state and the alpha
travelled (``revolutions``), and the flight goes on with impacts. The engine returns the end state's
angular velocity but not its slip velocity, so the rebuilt state is the rolling one; where that state
would not separate (its free path enters the ring within :data:`PROBE` s: the ball left while
slipping), the engine's own landing rule decides the shot (status ``engine_landing``). Otherwise (periodic rolling, a
steady motion, still on the rim at the end of the time) the shot ends on the rim.
"""

from __future__ import annotations

import math

import numpy as np

from rimroll.solver.engine.outcomes import FALL_IN, FALL_OUT
from rimroll.solver.physics.impact import impact
from rimroll.solver.physics.rim_frame import from_rim, to_rim
from rimroll.solver.physics.rolling import normal_force
from rimroll.solver.physics.shot_flight import Flight
from rimroll.solver.physics.shot_geometry import ring_distance

PROBE = 1e-3
"""[s] after a separation: the rebuilt free path must not be inside the ring then (see the module doc)."""


def capture_impact(pos, vel, spin, n, p, contact):
    """The rim impact of a ball at ``pos`` [m] with ``vel`` [m/s], ``spin`` [1/s], rim normal ``n``:
    ``(vel, spin, state)`` after it, ``state`` = (alpha, beta, omega1, omega2, omega3, slip) of a capture
    (slip [m/s]: what a Coulomb plastic impact would have left) or None when the ball bounces."""
    v_n = vel[0] * n[0] + vel[1] * n[1] + vel[2] * n[2]
    if not contact.e_rim * abs(v_n) < contact.v_cap or v_n >= 0.0:
        v2, w2, _ = impact(vel, spin, n, p.r, p.j, contact.e_rim, contact.mu_rim)
        return v2, w2, None
    v_c, w_c, _ = impact(vel, spin, n, p.r, p.j, 0.0, contact.mu_rim)
    slip = math.hypot(*to_rim(pos, v_c, w_c, p.R, p.r)[5:7])
    v_s, w_s, _ = impact(vel, spin, n, p.r, p.j, 0.0, math.inf)
    alpha, beta, w1, w2, w3 = to_rim(pos, v_s, w_s, p.R, p.r)[:5]
    if normal_force(beta, w1, w3, p.as_array()) < 0.0:  # (31): the ball cannot stay; it bounces
        v2, w2_, _ = impact(vel, spin, n, p.r, p.j, contact.e_rim, contact.mu_rim)
        return v2, w2_, None
    return v_s, w_s, (alpha, beta, w1, w2, w3, slip)


def roll(state, p, t_left: float) -> dict:
    """The rim engine's run of the captured ``state`` for ``t_left`` [s]: its ``outcome``, ``t_end``,
    ``revolutions``, and, if the ball left the rim, the flight's start ``position``, ``velocity``,
    ``spin`` (else None), and ``separates`` (False: it left while slipping, see the module doc)."""
    from rimroll.solver.engine.simulate import simulate

    alpha, beta, w1, w2, w3 = state[:5]
    res = simulate(np.array([[beta, w1, w2, w3]]), p, t_max=t_left, workers=1)
    out = {k: float(res[k][0]) for k in ("t_end", "revolutions")}
    out["outcome"] = int(res["outcome"][0])
    out["left"] = None
    if out["outcome"] in (FALL_IN, FALL_OUT):
        alpha_end = alpha + 2.0 * math.pi * out["revolutions"]
        out["left"] = from_rim(alpha_end, float(res["beta_end"][0]), float(res["omega1_end"][0]),
                               float(res["omega2_end"][0]), float(res["omega3_end"][0]), p.R, p.r, p.r + p.a)
        probe = Flight(p, out["left"][0], out["left"][1]).position(PROBE)
        out["separates"] = ring_distance(*probe, p.R) >= p.r + p.a
    return out
