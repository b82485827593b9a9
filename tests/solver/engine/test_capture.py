"""Capture onto the rim (solver.engine.shot_capture): the paper's frame both ways, and the hand-off to
the rim engine giving exactly the engine's outcome for the captured state."""

from __future__ import annotations

import math

import numpy as np
import pytest

from rimroll.solver import shots, simulate
from rimroll.solver.analysis import steady
from rimroll.solver.engine.shot_capture import capture_impact, roll
from rimroll.solver.physics.rim_frame import basis, from_rim, to_rim
from rimroll.solver.physics.rolling import normal_force
from rimroll.solver.physics.shot_geometry import ring_distance, ring_normal

P = shots.params_for("paper")


def test_rim_frame_is_the_papers():
    """n2 = n3 x n1 (4), an orthonormal basis; the centre is rho from the centre circle along n2 (the
    rim's normal); a rolling ball's contact point is at rest (v_G = omega x r n2) and the map back
    gives the same state."""
    rng = np.random.default_rng(3)
    for alpha, beta, w1, w2, w3 in rng.uniform(-3.0, 3.0, size=(50, 5)) * [1, 1, 20, 20, 20]:
        n1, n2, n3 = basis(alpha, beta)
        np.testing.assert_allclose(np.cross(n3, n1), n2, atol=1e-15)
        np.testing.assert_allclose(np.array([n1, n2, n3]) @ np.array([n1, n2, n3]).T, np.eye(3), atol=1e-15)
        pos, vel, spin = from_rim(alpha, beta, w1, w2, w3, P.R, P.r, P.r + P.a)
        assert ring_distance(*pos, P.R) == pytest.approx(P.r + P.a, rel=1e-14)
        np.testing.assert_allclose(ring_normal(*pos, P.R), n2, atol=1e-14)
        np.testing.assert_allclose(vel, np.cross(spin, P.r * np.array(n2)), atol=1e-13)
        back = to_rim(pos, vel, spin, P.R, P.r)
        assert math.remainder(back[0] - alpha, 2 * math.pi) == pytest.approx(0.0, abs=1e-12)
        assert math.remainder(back[1] - beta, 2 * math.pi) == pytest.approx(0.0, abs=1e-12)
        np.testing.assert_allclose(back[2:], [w1, w2, w3, 0.0, 0.0, 0.0], atol=1e-12)


def _captured(state, alpha=0.4, v_normal=1e-4):
    """A ball in the rolling ``state`` (beta, omega1, omega2, omega3) at ``alpha`` approaching the rim with
    ``v_normal`` [m/s] along -n2, through the shot's rim impact."""
    pos, vel, spin = from_rim(alpha, *state, P.R, P.r, P.r + P.a)
    n2 = basis(alpha, state[0])[1]
    vel = tuple(vel[i] - v_normal * n2[i] for i in range(3))
    return capture_impact(pos, vel, spin, ring_normal(*pos, P.R), P, shots.Contact())


@pytest.mark.slow
@pytest.mark.parametrize("perturb", [0.0, 0.3], ids=["steady", "perturbed"])
def test_capture_of_a_steady_motion_hands_the_engine_that_state(perturb):
    """A ball in a stable steady motion (47)-(48) (beta0 = 60 deg, omega30 = 30 1/s) with a normal speed of
    1e-4 m/s is captured in exactly that rolling state (no slip), and its rim phase is the engine's run of
    the state: same outcome, same time on the rim, same revolutions. Perturbed (omega1 = 0.3 1/s, so it
    is not steady) likewise."""
    state = steady.steady_state(math.radians(60.0), 30.0, P)
    state = np.array([state[0], state[1] + perturb, state[2], state[3]])
    assert normal_force(state[0], state[1], state[3], P.as_array()) > 0.0
    _, _, captured = _captured(state)
    assert captured is not None
    np.testing.assert_allclose(captured[1:5], state, rtol=1e-12, atol=1e-12)
    assert captured[5] == pytest.approx(0.0, abs=1e-12)
    on_rim = roll(captured, P, 3.0)
    direct = simulate(state[None, :], P, t_max=3.0, workers=1)
    assert on_rim["outcome"] == int(direct["outcome"][0])
    assert on_rim["t_end"] == pytest.approx(float(direct["t_end"][0]), rel=1e-9, abs=1e-12)
    assert on_rim["revolutions"] == pytest.approx(float(direct["revolutions"][0]), rel=1e-9, abs=1e-12)


def test_fast_normal_speed_bounces():
    """Above v_cap / e_rim of normal speed the ball rebounds (no capture), with -e_rim of its normal speed."""
    state = steady.steady_state(math.radians(60.0), 30.0, P)
    c = shots.Contact()
    v_n = 1.5 * c.v_cap / c.e_rim
    vel, _, captured = _captured(state, v_normal=v_n)
    assert captured is None
    n2 = basis(0.4, state[0])[1]
    assert np.dot(vel, n2) == pytest.approx(c.e_rim * v_n, rel=1e-12)
