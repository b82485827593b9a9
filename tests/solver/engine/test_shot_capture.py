"""A ball captured on the rim that leaves it while slipping: the flight goes on from the exact separation state.

The rim engine's end state carries the slip velocity (``u1_end``, ``u3_end``); the shot rebuilds the 3-D
position, velocity and spin at the separation from it. Checked against independent computations: the
contact point's velocity v + omega x (-r n2) of the rebuilt state is the engine's slip velocity, and
its mechanical energy (m |v|^2 / 2 + j m r^2 |omega|^2 / 2 + m g z) is the engine's energy at the end
(its energy at the start, (60), less the loss it reports).
"""

import math

import numpy as np
import pytest

from rimroll.solver import shots, simulate
from rimroll.solver.engine.shot_capture import roll_batch
from rimroll.solver.physics.impact import kinetic_energy
from rimroll.solver.physics.rim_frame import basis, from_rim

P = shots.params_for("paper")
SLIPPING = (1.32299784, 2.50418158, 90.34715956, 14.37409922)
"""(beta, omega1, omega2, omega3) of a rolling start that slips at once and leaves the rim slipping (mu = 1)."""


def energy(pos, vel, spin, p):
    """Mechanical energy [J] of the ball in the shot frame (z up, potential zero at the rim plane)."""
    return kinetic_energy(vel, spin, p.m, p.r, p.j) + p.m * p.g * pos[2]


def test_slipping_separation_state_has_the_engines_slip_and_energy():
    alpha0 = 0.7
    run = roll_batch([((alpha0, *SLIPPING, 0.0), 2.0)], P)[0]
    res = simulate(np.array([SLIPPING]), P, t_max=2.0, workers=1)
    u1, u3 = float(res["u1_end"][0]), float(res["u3_end"][0])
    assert run["outcome"] in (0, 1) and res["slip_phases"][0] >= 1
    assert math.hypot(u1, u3) > 1.0  # it left the rim slipping fast: a rolling rebuild would be far off
    pos, vel, spin = run["left"]
    # the contact point: centre minus r n2, n2 from the nearest point of the centre circle to the centre
    q = math.hypot(pos[0], pos[1])
    n2 = np.array([pos[0] - P.R * pos[0] / q, pos[1] - P.R * pos[1] / q, pos[2]])
    n2 /= np.linalg.norm(n2)
    v_contact = np.asarray(vel) + np.cross(spin, -P.r * n2)
    alpha_end = alpha0 + 2.0 * math.pi * float(res["revolutions"][0])
    n1, _, n3 = basis(alpha_end, float(res["beta_end"][0]))
    assert v_contact @ n2 == pytest.approx(0.0, abs=1e-12)
    assert v_contact @ np.array(n1) == pytest.approx(u1, rel=1e-12, abs=1e-12)
    assert v_contact @ np.array(n3) == pytest.approx(u3, rel=1e-12, abs=1e-12)
    assert np.array(spin) @ np.array(n1) == pytest.approx(res["omega1_end"][0], rel=1e-12)
    # energy: the engine's start energy less the loss it reports (energy_drift x its scale)
    e0 = energy(*from_rim(alpha0, *SLIPPING, P.R, P.r, P.r + P.a), P)
    scale = max(abs(e0), P.m * P.g * (P.r + P.a))
    e1 = energy(pos, vel, spin, P)
    assert e1 < e0
    assert e0 - e1 == pytest.approx(float(res["energy_drift"][0]) * scale, rel=1e-9)
    assert run["separates"]


def test_captured_sliding_shot_flies_on_from_the_separation():
    """A free throw captured with a slip (slip_cap > 0) rolls on the rim, leaves it and its flight goes
    on from where the engine left it (the trace's flight starts at the rim phase's last sample); no
    shot of a small map ends by the landing-rule guard."""
    release = {"speed": 7.5769230769230775, "angle": math.radians(40.64102564102564)}
    tr = shots.trace_shot(release, P)
    assert tr["slip_cap"] > 0.1 and tr["time_on_rim"] > 0.0
    assert shots.STATUS_MEANINGS[tr["status"]] == "ok"
    on = np.flatnonzero(tr["phase"] == 1)
    last = on[-1]
    assert tr["phase"][last + 1] == 0
    for c in ("x", "y", "z"):
        assert tr[c][last + 1] == pytest.approx(tr[c][last], abs=1e-12)
    assert tr["time"][last + 1] == pytest.approx(tr["time"][last], abs=1e-12)
