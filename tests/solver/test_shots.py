"""The shot loop (solver.shots): grazes found, outcomes, budgets and bad input."""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy.integrate import solve_ivp
from scipy.optimize import minimize_scalar

from rimroll.solver import Params, shots

P = shots.params_for("paper")
CODE = {name: i for i, name in enumerate(shots.OUTCOME_MEANINGS)}
FREE_THROW = dict(distance=4.19, height=0.92)


def _ring_distance(x, y, z, R):
    return math.hypot(math.hypot(x, y) - R, z)


def _vacuum_path(release, g):
    v, el, az = release["speed"], release["angle"], release.get("azimuth", 0.0)
    x0, y0, z0 = -release["distance"], release.get("lateral", 0.0), -release["height"]
    vx, vy, vz = v * math.cos(el) * math.cos(az), v * math.cos(el) * math.sin(az), v * math.sin(el)
    return lambda t: (x0 + vx * t, y0 + vy * t, z0 + vz * t - 0.5 * g * t * t)


def _drag_path(release, p):
    v, el = release["speed"], release["angle"]
    k = 0.5 * p.rho_air * p.C_D * math.pi * p.r ** 2 / p.m

    def rhs(_, s):
        vel = s[3:]
        return np.concatenate([vel, -k * np.linalg.norm(vel) * vel - np.array([0.0, 0.0, p.g])])

    sol = solve_ivp(rhs, (0.0, 2.0), [-release["distance"], 0.0, -release["height"], v * math.cos(el), 0.0,
                                      v * math.sin(el)], method="DOP853", rtol=1e-13, atol=1e-15, dense_output=True)
    return lambda t: tuple(sol.sol(t)[:3])


def _closest_approach(path, R, window):
    """Least distance [m] of the path from the ring's centre circle in the time ``window``: the least of
    4001 samples, refined by scipy's bounded minimisation between its neighbours."""
    t = np.linspace(*window, 4001)
    i = int(np.argmin([_ring_distance(*path(s), R) for s in t]))
    best = minimize_scalar(lambda s: _ring_distance(*path(s), R), bounds=(t[max(i - 1, 0)], t[min(i + 1, 4000)]),
                           method="bounded", options={"xatol": 1e-12})
    assert window[0] + 1e-3 < best.x < window[1] - 1e-3  # a true minimum, inside the window
    return best.fun, best.x


def _touches(release, p, t_star):
    """Whether the shot's first impact is on the ring within 1e-4 s of the closest approach ``t_star``."""
    res = shots.trace_shot(release, p, shots.Contact())
    if not res["impact_time"].size:
        return False
    return int(res["impact_kind"][0]) == 1 and abs(float(res["impact_time"][0]) - t_star) < 1e-4


# A shot near the front rim (in-plane) and one passing the ring obliquely (lateral offset, azimuth).
FRONT = dict(speed=7.17, angle=math.radians(55.0), **FREE_THROW)
OBLIQUE = dict(speed=6.92, angle=math.radians(55.0), lateral=0.2, azimuth=-0.01, **FREE_THROW)


@pytest.mark.parametrize("release", [FRONT, OBLIQUE], ids=["front", "oblique"])
def test_vacuum_graze_is_found_and_a_near_miss_is_not(release):
    """The ring's tube radius a set so that the ball centre's closest approach (scipy on the exact distance) is rho
    - 1e-9 m: the first impact is on the ring there; rho + 1e-9 m: not there."""
    path = _vacuum_path(release, P.g)
    t_cross = 1.0 * release["distance"] / (release["speed"] * math.cos(release["angle"]))
    d_min, t_star = _closest_approach(path, P.R, (0.6 * t_cross, 1.2 * t_cross))
    assert P.r < d_min < 0.2
    assert _touches(release, P.replace(a=d_min - P.r + 1e-9), t_star)
    assert not _touches(release, P.replace(a=d_min - P.r - 1e-9), t_star)


def test_drag_graze_is_found_and_a_near_miss_is_not():
    """As the vacuum graze, on the path with drag (rho_air = 1.2) integrated by scipy at rtol 1e-13."""
    p = P.replace(rho_air=1.2)
    release = dict(FRONT, speed=7.49)
    path = _drag_path(release, p)
    d_min, t_star = _closest_approach(path, p.R, (0.5, 1.05))
    assert P.r < d_min < 0.2
    assert _touches(release, p.replace(a=d_min - p.r + 1e-9), t_star)
    assert not _touches(release, p.replace(a=d_min - p.r - 1e-9), t_star)


def test_shot_through_the_centre_is_a_swish_and_ends_rho_below():
    """The path through the hoop's centre at 58 deg touches nothing (swish); it ends when the centre is
    rho below the rim plane, at the closed-form time of z(t) = -rho."""
    theta = math.radians(58.0)
    v = shots.speed_to_reach(theta, 4.19, 0.92, P)
    res = shots.simulate_shots(dict(speed=v, angle=theta, **FREE_THROW), P, shots.Contact())
    assert int(res["outcome"]) == CODE["swish"] and int(res["n_impacts"]) == 0
    vz, rho = v * math.sin(theta), P.r + P.a
    assert float(res["t_end"]) == pytest.approx((vz + math.sqrt(vz * vz - 2 * P.g * (0.92 - rho))) / P.g, rel=1e-13)
    assert math.isnan(float(res["beta_cap"]))


def test_short_and_long_shots():
    """Far too slow: an airball short of the ring; far too fast: hits the board first."""
    res = shots.simulate_shots(dict(speed=np.array([6.0, 8.0]), angle=math.radians(52.0), **FREE_THROW), P,
                               shots.Contact())
    assert int(res["outcome"][0]) == CODE["airball"]
    assert int(res["first_contact"][1]) == 2
    assert res["n_impacts"][1] >= 1


def test_budgets_end_a_shot_with_a_status():
    """A rim shot with no impacts allowed, and a shot with 0.1 s: unfinished, with the status that says why."""
    release = dict(speed=7.05, angle=math.radians(52.0), **FREE_THROW)
    res = shots.simulate_shots(release, P, shots.Contact(), max_impacts=0)
    assert int(res["outcome"]) == CODE["unfinished"]
    assert shots.STATUS_MEANINGS[int(res["status"])] == "impact_budget"
    res = shots.simulate_shots(release, P, shots.Contact(), t_max=0.1)
    assert shots.STATUS_MEANINGS[int(res["status"])] == "time_budget"
    assert float(res["t_end"]) == pytest.approx(0.1)


def test_impact_counts_add_up():
    """Over a small map: impacts = rim + board impacts; a swish or an airball has none; the first
    contact is none exactly when there was no impact. (v_cap = 0: no capture, so no rim engine.)"""
    res = shots.simulate_shots(dict(speed=np.linspace(6.8, 7.8, 9)[:, None],
                                    angle=np.radians(np.linspace(45.0, 60.0, 6))[None, :], **FREE_THROW),
                               P, shots.Contact(v_cap=0.0))
    assert np.all(np.isnan(res["beta_cap"])) and np.all(res["rim_outcome"] == -1)
    assert np.array_equal(res["n_impacts"], res["n_rim_impacts"] + res["n_board_impacts"])
    clean = np.isin(res["outcome"], [CODE["swish"], CODE["airball"]])
    assert np.all(res["n_impacts"][clean] == 0)
    assert np.array_equal(res["first_contact"] == 0, res["n_impacts"] == 0)
    assert res["outcome"].shape == (9, 6) and res["outcome"].dtype == np.int8


# ---------------------------------------------------------------- bad input
@pytest.mark.parametrize("key, value", [
    ("speed", 0.0), ("speed", -1.0), ("speed", 60.0), ("speed", math.nan), ("angle", 2.0), ("angle", "high"),
    ("distance", 0.0), ("distance", 31.0), ("height", 6.0), ("lateral", 16.0), ("azimuth", -2.0),
    ("backspin", 501.0), ("sidespin", -501.0), ("height", math.inf),
])
def test_bad_release_is_refused_naming_the_key(key, value):
    release = {**dict(speed=7.0, angle=0.9), key: value}
    with pytest.raises(ValueError, match=f"`{key}`"):
        shots.simulate_shots(release, P)


def test_missing_or_unknown_release_key():
    with pytest.raises(ValueError, match="`angle`"):
        shots.simulate_shots(dict(speed=7.0), P)
    with pytest.raises(ValueError, match="spin"):
        shots.simulate_shots(dict(speed=7.0, angle=0.9, spin=3.0), P)


@pytest.mark.parametrize("field, value", [
    ("e_rim", 1.1), ("e_rim", -0.1), ("mu_rim", -1.0), ("e_board", 2.0), ("mu_board", math.nan),
    ("v_cap", -0.1), ("v_cap", math.inf),
])
def test_bad_contact_is_refused_naming_the_field(field, value):
    with pytest.raises(ValueError, match=f"`{field}`"):
        shots.simulate_shots(dict(speed=7.0, angle=0.9), P, shots.Contact()._replace(**{field: value}))


@pytest.mark.parametrize("kwargs, word", [
    (dict(geometry="fiba"), "geometry"), (dict(t_max=0.0), "t_max"), (dict(t_max=math.nan), "t_max"),
    (dict(max_impacts=-1), "max_impacts"), (dict(max_impacts=2.5), "max_impacts"),
    (dict(max_impacts=True), "max_impacts"),
])
def test_bad_settings_are_refused(kwargs, word):
    with pytest.raises(ValueError, match=word):
        shots.simulate_shots(dict(speed=7.0, angle=0.9), P, shots.Contact(), **kwargs)


def test_params_for_sets_the_ring_of_the_geometry():
    """paper: Table 1 ring; regulation: FIBA 450 mm inner diameter, 18 mm rod; the board 0.151 m from the
    inner edge of either."""
    assert (shots.params_for("paper").R, shots.params_for("paper").a) == (Params().R, Params().a)
    reg = shots.params_for("regulation", mu=0.5)
    assert 2.0 * (reg.R - reg.a) == pytest.approx(0.450) and 2.0 * reg.a == pytest.approx(0.018) and reg.mu == 0.5
    assert shots.board_x(reg, "regulation") - (reg.R - reg.a) == pytest.approx(0.151)


def test_board_impact_against_the_closed_form():
    """A flat fast shot hits the board's face first: at x = board_x - r at the time (L + board_x - r) /
    (v cos theta), and it leaves with x-velocity -e_board times its approach (the next samples' slope)."""
    release = dict(speed=8.0, angle=math.radians(45.0), **FREE_THROW)
    res = shots.trace_shot(release, P, shots.Contact())
    assert int(res["impact_kind"][0]) == 2
    level = shots.board_x(P, "paper") - P.r
    t_hit = (4.19 + level) / (8.0 * math.cos(math.radians(45.0)))
    assert float(res["impact_time"][0]) == pytest.approx(t_hit, rel=1e-13)
    assert float(res["impact_x"][0]) == pytest.approx(level, abs=1e-12)
    after = (res["time"] > t_hit) & (res["time"] < (res["impact_time"][1] if res["impact_time"].size > 1 else 9))
    t, x = res["time"][after], res["x"][after]
    slope = (x[-1] - x[0]) / (t[-1] - t[0])
    assert slope == pytest.approx(-shots.Contact().e_board * 8.0 * math.cos(math.radians(45.0)), rel=1e-12)


@pytest.mark.slow
def test_gentle_drop_on_the_top_of_the_tube_is_captured():
    """A ball let go 1 mm above the top of the tube (beta = pi/2) at 0.05 m/s meets it at
    sqrt(0.05^2 + 2 g 1e-3) m/s, below v_cap / e_rim: it is captured at beta = pi/2 with no spin and
    no slip, and its rim phase ends as the engine's run of (pi/2, 0, 0, 0) does."""
    from rimroll.solver import simulate

    rho = P.r + P.a
    release = dict(speed=0.05, angle=-math.pi / 2, distance=P.R, height=-(rho + 1e-3))
    res = shots.simulate_shots(release, P, shots.Contact(), t_max=2.0)
    assert float(res["beta_cap"]) == pytest.approx(math.pi / 2, abs=1e-9)
    np.testing.assert_allclose([res[k] for k in ("omega1_cap", "omega2_cap", "omega3_cap", "slip_cap")], 0.0,
                               atol=1e-9)
    direct = simulate(np.array([[math.pi / 2, 0.0, 0.0, 0.0]]), P, t_max=2.0 - float(res["t_end"]) +
                      float(res["time_on_rim"]), workers=1)
    assert int(res["rim_outcome"]) == int(direct["outcome"][0])
    assert int(res["n_impacts"]) == 1


def test_geometry_must_match_the_ring_of_params():
    """geometry names the ring that params must have: the paper's Params with geometry="regulation" is
    refused (naming both rings), params_for("regulation") accepted."""
    release = dict(speed=7.0, angle=0.9)
    with pytest.raises(ValueError, match="`geometry` 'regulation'.*params_for"):
        shots.simulate_shots(release, P, geometry="regulation")
    res = shots.simulate_shots(release, shots.params_for("regulation"), geometry="regulation")
    assert res["outcome"].shape == ()
