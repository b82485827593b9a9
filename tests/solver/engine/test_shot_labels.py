"""Shots built on purpose: a rim-and-board double contact, misses to the left and to the right."""

from __future__ import annotations

import math

import numpy as np
import pytest

from rimroll.solver import shots
from rimroll.solver.engine.shot_loop import DOUBLE_WINDOW

P = shots.params_for("paper")


def _release_through(point, velocity, t_before: float) -> dict:
    """The release (vacuum) whose centre passes ``point`` [m] with ``velocity`` [m/s] ``t_before`` [s] later."""
    v0 = np.array(velocity, float) + np.array([0.0, 0.0, P.g * t_before])
    p0 = np.array(point, float) - v0 * t_before + np.array([0.0, 0.0, 0.5 * P.g * t_before ** 2])
    return dict(speed=float(np.linalg.norm(v0)), angle=math.atan2(v0[2], v0[0]), distance=float(-p0[0]),
                height=float(-p0[2]))


def test_rim_and_board_at_once_is_a_double_contact():
    """The ball arrives where it touches the back of the ring and the board's face at once: its centre
    at x = x_board - r and at the distance rho = r + a from the ring's centre circle, in the plane y = 0
    (z = sqrt(rho^2 - (x - R)^2)). Both impacts are found at the arrival time (to 1e-9 s), within
    DOUBLE_WINDOW of each other, and the shot counts a double contact."""
    rho = P.r + P.a
    x = shots.board_x(P) - P.r
    z = math.sqrt(rho ** 2 - (x - P.R) ** 2)
    t_hit = 0.8
    release = _release_through((x, 0.0, z), (0.5, 0.0, -3.0), t_hit)
    tr = shots.trace_shot(release, P, shots.Contact(v_cap=0.0))
    first_two = tr["impact_time"][:2]
    assert first_two == pytest.approx([t_hit, t_hit], abs=1e-9)
    assert sorted(tr["impact_kind"][:2].tolist()) == [1, 2]
    assert first_two[1] - first_two[0] <= DOUBLE_WINDOW
    assert tr["n_double_contacts"] >= 1
    assert tr["n_rim_impacts"] >= 1 and tr["n_board_impacts"] >= 1


@pytest.mark.parametrize("side", [1.0, -1.0])
def test_side_rim_hits_miss_left_and_right(side):
    """A free throw aimed (azimuth) at the point 0.32 m to the side of the hoop's axis, beyond the ring
    (R + 0.095 m, within rho of its centre circle): it hits the outer side of the ring and falls off
    that side: miss_left for +y (the shooter's left), miss_right for -y; the two are mirror images."""
    y_target = side * 0.32
    distance = math.hypot(4.19, y_target)
    angle = math.radians(50.0)
    speed = shots.speed_to_reach(angle, distance, 0.92, P)
    res = shots.trace_shot(dict(speed=speed, angle=angle, azimuth=math.atan2(y_target, 4.19)), P)
    assert shots.OUTCOME_MEANINGS[res["outcome"]] == ("miss_left" if side > 0 else "miss_right")
    assert shots.FIRST_CONTACT_MEANINGS[res["first_contact"]] == "rim"
    assert np.sign(res["y"][-1]) == side and abs(res["y"][-1]) > abs(res["x"][-1])
    mirror = shots.trace_shot(dict(speed=speed, angle=angle, azimuth=-math.atan2(y_target, 4.19)), P)
    np.testing.assert_allclose(mirror["y"], -res["y"], atol=1e-9)
    np.testing.assert_allclose(mirror["x"], res["x"], atol=1e-9)
