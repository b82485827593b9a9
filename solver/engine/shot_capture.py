"""Capture of a shot onto the rim and its hand-off to the rim engine (``simulate``).

Rule (docs/shots.md): at a rim impact whose rebound speed e_rim |v_n| would be below v_cap, the
impact is plastic instead (e = 0: the normal speed is removed) and its friction brings the contact
point to rest (a full stick, P_t = -m u_t / (1 + 1/j)). If the Coulomb impact (|P_t| <= mu_rim P_n)
would have left a slip, that slip speed is recorded as ``slip_cap`` (> 0: a sliding capture, the
stick then needs more than mu_rim P_n; the engine starts from rolling states only). The ball stays on
the rim if the rolling normal force F2 of (31) is >= 0 there; its paper state (beta, omega1, omega2,
omega3), rolling, goes to ``simulate`` for the time left. When the engine says the ball left the rim
(fall_in, fall_out), the 3-D state at the separation is rebuilt from its end state (beta, omega1,
omega2, omega3 and the slip velocity u1, u3: ``simulate``'s ``u1_end``, ``u3_end``, zero when it left
rolling) and the alpha travelled (``revolutions``), and the flight goes on with impacts from that exact
state (:func:`rim_frame.from_rim`). A guard stays: where the rebuilt free path would enter the ring
within :data:`PROBE` s (it does not for a separation at F2 = 0; none was seen in the 40 x 40 free-throw
map), the engine's own landing rule decides the shot (status ``engine_landing``). Otherwise (periodic
rolling, a steady motion, still on the rim at the end of the time) the shot ends on the rim.
"""

from __future__ import annotations

import math

import numpy as np

from rimroll.solver.engine.outcomes import FALL_IN, FALL_OUT, ON_RIM_AT_T_MAX
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
    """The rim engine's run of the captured ``state`` for ``t_left`` [s] (:func:`roll_batch` of one)."""
    return roll_batch([(state, t_left)], p)[0]


def roll_batch(requests, p) -> list[dict]:
    """The rim engine's runs of captured states, ``requests`` = [(state, t_left [s]), ...], in ONE call of
    ``simulate`` to the largest t_left; a run still on the rim at its own t_left (or falling after it) is
    cut there (outcome on_rim_at_t_max). Each: ``outcome``, ``t_end`` [s], ``revolutions``, and, if the ball
    left the rim, the flight's start ``left`` = (position, velocity, spin) at the separation (else None) and
    ``separates`` (False: the rebuilt free path would enter the ring at once, see the module doc)."""
    from rimroll.solver.engine.simulate import simulate

    states = np.array([[s[1], s[2], s[3], s[4]] for s, _ in requests])
    res = simulate(states, p, t_max=max(t for _, t in requests), workers=1)
    return [_run_of(res, i, state, t_left, p) for i, (state, t_left) in enumerate(requests)]


def _run_of(res: dict, i: int, state, t_left: float, p) -> dict:
    """Lane ``i`` of the engine's result ``res`` as :func:`roll_batch` returns it."""
    out = {"t_end": float(res["t_end"][i]), "revolutions": float(res["revolutions"][i]),
           "outcome": int(res["outcome"][i]), "left": None, "separates": False}
    if out["t_end"] > t_left:  # past this shot's own time budget: on the rim at its t_max
        return {**out, "t_end": t_left, "outcome": ON_RIM_AT_T_MAX}
    if out["outcome"] in (FALL_IN, FALL_OUT):
        alpha_end = state[0] + 2.0 * math.pi * out["revolutions"]
        out["left"] = from_rim(alpha_end, float(res["beta_end"][i]), float(res["omega1_end"][i]),
                               float(res["omega2_end"][i]), float(res["omega3_end"][i]), p.R, p.r, p.r + p.a,
                               float(res["u1_end"][i]), float(res["u3_end"][i]))
        probe = Flight(p, out["left"][0], out["left"][1]).position(PROBE)
        out["separates"] = ring_distance(*probe, p.R) >= p.r + p.a
    return out
