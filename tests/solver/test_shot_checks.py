"""Independent checks of the shot model: computations that do not use the solver's shot code.

The swish (clean make) window of a shot in vacuum is pure geometry: the ball's centre follows the
parabola x(t) = -L + v cos(theta) t, z(t) = -h + v sin(theta) t - g t^2 / 2 in the vertical plane
through the hoop's axis (y = 0; frame of docs/shots.md: origin at the ring's centre, z up, x towards
the board), and the ball touches the ring exactly when its centre comes within rho = r + a of the
ring's centre circle (radius R in the plane z = 0). In that plane the distance to the circle is
sqrt((|x| - R)^2 + z^2), so its square is the smaller of two quartics in t,
(x - R)^2 + z^2 and (x + R)^2 + z^2, whose minima over an interval are at its ends or at the real
roots of their cubic derivatives (numpy's polynomial roots). A shot is a swish when the centre
crosses the rim plane inside the ring and never comes within rho of the circle before it is rho
below the rim plane (then it cannot touch the ring any more). The window's edges follow by
bisection on the speed.

A second, cruder computation (the path sampled densely) checks this one; the solver's outcomes
(``shots.simulate_shots``, bisection on the speed) are compared with it where the solver is installed.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from tests.helpers.swish_geometry import (
    FREE_THROW,
    PAPER_RING,
    G,
    descending_time,
    is_swish,
    regulation_ring,
    speed_through_centre,
    swish_window,
)


def _sampled_swish(v: float, theta: float, L: float, h: float, ring: dict, n: int = 200_001) -> bool:
    """:func:`is_swish` by brute force: the distance on ``n`` samples of the path."""
    t_end = descending_time(v, theta, h, ring["r"] + ring["a"])
    t = np.linspace(0.0, t_end, n)
    x = -L + v * math.cos(theta) * t
    z = -h + v * math.sin(theta) * t - 0.5 * G * t * t
    clear = np.hypot(np.abs(x) - ring["R"], z).min() > ring["r"] + ring["a"]
    x_cross = -L + v * math.cos(theta) * descending_time(v, theta, h, 0.0)
    return bool(clear and abs(x_cross) < ring["R"])


ANGLES = (52.0, 55.0, 60.0)  # [deg] release angles with a swish window at a free throw


@pytest.mark.parametrize("degrees", ANGLES)
def test_exact_window_agrees_with_a_sampled_path(degrees):
    """The roots-of-quartics window and the one of a densely sampled path agree (to the sampling's
    resolution: 200 000 samples of about 1 s)."""
    theta = math.radians(degrees)
    exact = swish_window(theta, *FREE_THROW, PAPER_RING)
    sampled = swish_window(theta, *FREE_THROW, PAPER_RING,
                           swish=lambda v: _sampled_swish(v, theta, *FREE_THROW, PAPER_RING))
    np.testing.assert_allclose(sampled, exact, atol=2e-5)
    assert exact[0] < speed_through_centre(theta, *FREE_THROW) < exact[1]


def test_the_clean_window_at_52_degrees():
    """The question: at a 52 deg free throw the clean window is ~0.03 m/s wide with the paper's ring
    (inner diameter 0.43 m) and ~0.04 m/s with a regulation ring (0.45 m), narrower than a player's
    release-speed spread of 0.05-0.13 m/s (Slegers, Lee and Wong 2021). Found: 0.0305 m/s (paper);
    0.044-0.046 m/s for a 450 mm ring with a 16-20 mm rod, 0.050 m/s at 459 mm and 20 mm."""
    theta = math.radians(52.0)
    low, high = swish_window(theta, *FREE_THROW, PAPER_RING)
    assert 0.025 < high - low < 0.035
    assert high - low < 0.05  # below the least release spread of the study
    widths = [np.diff(swish_window(theta, *FREE_THROW, regulation_ring(rod, d)))[0]
              for rod in (0.016, 0.020) for d in (0.450, 0.459)]
    assert all(0.04 < w < 0.052 for w in widths)
    assert min(widths) > high - low  # a wider inner diameter, a wider window


def test_no_swish_at_a_flat_release():
    """At 45 deg the centre's entry is too flat for the ball to pass the paper's ring untouched even
    through its centre: the clearance is below rho (the ring looks narrower than the ball)."""
    theta = math.radians(45.0)
    v0 = speed_through_centre(theta, *FREE_THROW)
    assert not any(is_swish(v, theta, *FREE_THROW, PAPER_RING) for v in np.linspace(0.95 * v0, 1.05 * v0, 2001))


# ---------------------------------------------------------------- against the solver
def _shots():
    return pytest.importorskip("rimroll.solver.shots", reason="the solver's shot model is not installed")


def _ring_of(shots, geometry: str) -> dict:
    p = shots.params_for(geometry)
    return dict(R=p.R, a=p.a, r=p.r)


@pytest.mark.parametrize("degrees", ANGLES)
def test_solver_swish_window_against_geometry(degrees):
    """The speeds at which ``simulate_shots`` (vacuum, paper ring) says swish form the window of the
    independent geometry, bisected on the speed to 1e-9 m/s."""
    from rimroll.solver import Params

    shots = _shots()
    swish_code = list(shots.OUTCOME_MEANINGS).index("swish")
    ring = _ring_of(shots, "paper")
    theta = math.radians(degrees)
    L, h = FREE_THROW

    def solver_swish(v):
        res = shots.simulate_shots({"speed": np.array([v]), "angle": np.array([theta]), "distance": L, "height": h},
                                   Params(), shots.Contact(), geometry="paper")
        return int(res["outcome"][0]) == swish_code

    expected = swish_window(theta, L, h, ring)
    found = swish_window(theta, L, h, ring, swish=solver_swish)
    np.testing.assert_allclose(found, expected, atol=1e-7)


def test_brancazio_least_speed_angle():
    """Brancazio (Am. J. Phys. 49 (1981) 356): the least release speed that reaches the hoop's
    centre is at 45 deg + atan(dh / L) / 2; ``shots.speed_to_reach`` minimised over the angle finds
    it to 1e-6 rad, for a free throw and two other shots."""
    from scipy.optimize import minimize_scalar

    from rimroll.solver import Params

    shots = _shots()
    for L, h in (FREE_THROW, (6.75, 0.9), (2.0, 0.3)):
        def speed2(theta, L=L, h=h):
            return float(shots.speed_to_reach(theta, L, h, Params())) ** 2

        found = minimize_scalar(speed2, bracket=(0.7, 0.9, 1.2), method="brent", tol=1e-12).x
        assert found == pytest.approx(math.radians(45.0) + 0.5 * math.atan(h / L), abs=1e-6)
        assert speed2(found) == pytest.approx(speed_through_centre(found, L, h) ** 2, rel=1e-9)
