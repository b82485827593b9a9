"""The ``shot-probability`` study against computations of its own: an independent Monte Carlo draw of
the same noisy shots (another seed, numpy's own normal sampler, scipy's Wilson interval), and, in
vacuum with every rim or board contact counted as a miss, the probability of the closed-form swish
window (the geometry of ``tests/helpers/swish_geometry.py``) under the same Gaussian noise, by quadrature."""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy import stats
from scipy.integrate import simpson

from rimroll import solver
from rimroll.solver import shots
from rimroll.workflows import shot_probability as sp
from tests.helpers.swish_geometry import FREE_THROW, PAPER_RING, is_swish, speed_through_centre, swish_window

MAKE_CODES = [list(shots.OUTCOME_MEANINGS).index(n) for n in ("swish", "make_rim", "make_board", "make_roll")]


def _settings(**changes) -> dict:
    return {**sp.SETTINGS, **changes}


def _study_estimate(s: dict, speed: float, angle: float) -> dict:
    out = sp._compute([np.array([[speed]]), np.array([[angle]])], solver.Params(), s)
    return {k: float(np.asarray(v).ravel()[0]) for k, v in out.items()}


@pytest.mark.parametrize("speed, angle", [(7.20, 52.0), (7.30, 57.0)])
def test_estimate_within_wilson_interval_of_an_independent_draw(speed, angle):
    """Another draw of the same noisy releases (seed 2024, ``Generator.normal``, not the study's
    ``noise_draws``) gives a Wilson interval (scipy's, 99 %) that holds the study's estimate."""
    n = 600
    s = _settings(draws=n, seed=0)
    est = _study_estimate(s, speed, angle)
    rng = np.random.default_rng(2024)
    release = {"speed": rng.normal(speed, s["sd_speed"], n),
               "angle": np.radians(rng.normal(angle, s["sd_angle"], n)),
               "backspin": rng.normal(s["backspin"], s["sd_backspin"], n),
               "azimuth": np.radians(rng.normal(0.0, s["sd_azimuth"], n)),
               "distance": s["distance"], "height": s["height"]}
    res = shots.simulate_shots(release, shots.params_for("paper"), shots.Contact(), geometry="paper")
    k = int(np.isin(res["outcome"], MAKE_CODES).sum())
    ci = stats.binomtest(k, n).proportion_ci(confidence_level=0.99, method="wilson")
    assert 0.05 < k / n < 0.95  # a release where the test can fail either way
    assert ci.low <= est["p_make"] <= ci.high, (est["p_make"], k / n, ci)
    # and the study's own interval is scipy's Wilson interval of its count
    own = stats.binomtest(round(est["p_make"] * n), n).proportion_ci(confidence_level=0.95, method="wilson")
    assert est["p_make_lower"] == pytest.approx(own.low, abs=1e-12)
    assert est["p_make_upper"] == pytest.approx(own.high, abs=1e-12)
    kinds = sum(est[f"p_{kind}"] for kind in sp.MAKES)
    assert kinds == pytest.approx(est["p_make"], abs=1e-12)


def _window_probability(speed: float, angle_deg: float, sd_speed: float, sd_angle_deg: float) -> float:
    """P(swish) of a release normal about (speed, angle) in vacuum, in the vertical plane through the
    hoop's axis: the integral over the angle's density of the speed's probability to fall in the
    closed-form window at that angle (Simpson's rule over +-6 SD; no window: 0)."""
    L, h = FREE_THROW
    theta0, sd = math.radians(angle_deg), math.radians(sd_angle_deg)
    thetas = np.linspace(theta0 - 6 * sd, theta0 + 6 * sd, 121)
    inside = []
    for t in thetas:
        if not is_swish(speed_through_centre(t, L, h), t, L, h, PAPER_RING):
            inside.append(0.0)
            continue
        low, high = swish_window(t, L, h, PAPER_RING)
        inside.append(stats.norm.cdf(high, speed, sd_speed) - stats.norm.cdf(low, speed, sd_speed))
    return float(simpson(np.array(inside) * stats.norm.pdf(thetas, theta0, sd), x=thetas))


@pytest.mark.parametrize("speed, angle", [(7.17, 53.0), (7.30, 58.0)])
def test_swish_only_in_vacuum_is_the_closed_form_window(speed, angle):
    """makes = swish_only, no spin or sideways noise, vacuum: the study's P(make) is the probability
    of the closed-form swish window under the same Gaussian speed and angle noise (within its 99 %
    Wilson interval)."""
    n = 2000
    s = _settings(draws=n, makes="swish_only", sd_backspin=0.0, sd_azimuth=0.0, confidence=0.99)
    est = _study_estimate(s, speed, angle)
    exact = _window_probability(speed, angle, s["sd_speed"], s["sd_angle"])
    assert 0.05 < exact < 0.95
    assert est["p_rim"] == est["p_roll"] == est["p_board"] == 0.0
    assert est["p_make"] == est["p_swish"]
    assert est["p_make_lower"] <= exact <= est["p_make_upper"], (est["p_make"], exact)


def test_common_random_numbers_and_bad_settings():
    """Every nominal release sees the same draws (a shift of the nominal speed shifts every draw by it),
    and a bad spread or count is refused with a message naming it."""
    s = _settings(draws=5)
    a = sp.noisy_releases(s, np.array([7.0, 7.1]), np.array([50.0, 50.0]))
    assert np.allclose(a["speed"][1] - a["speed"][0], 0.1)
    assert np.array_equal(a["angle"][0], a["angle"][1])
    for key, value in (("sd_speed", -0.1), ("sd_angle", math.nan), ("draws", 0), ("confidence", 1.0)):
        with pytest.raises(ValueError, match=key):
            sp.check_noise({**s, key: value})
    with pytest.raises(ValueError, match="makes"):
        sp.make_counts(np.zeros((1, 3)), "rims")
