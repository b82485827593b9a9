"""The opt-in Magnus lift of the shot's flight (solver.physics.shot_air) against scipy and in its direction."""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy.integrate import solve_ivp

from rimroll.solver import shots
from rimroll.solver.physics.shot_flight import Flight

P = shots.params_for("paper", rho_air=1.2)


def _lift_reference(p, position, velocity, spin, times):
    """Centre positions [m] at ``times`` from scipy (DOP853, rtol 1e-13) with gravity, drag
    -k |v| v and the lift 1/2 rho_air A C_L |v|^2 (omega x v) / |omega x v| / m, C_L of Sawicki, Hubbard
    and Stronge, Am. J. Phys. 71 (2003) 1152: 1.5 S (S <= 0.1), 0.09 + 0.6 S above, S = r |omega_perp| / |v|."""
    area = math.pi * p.r ** 2
    k = 0.5 * p.rho_air * p.C_D * area / p.m
    w = np.asarray(spin, float)

    def rhs(_, s):
        v = s[3:]
        speed = np.linalg.norm(v)
        cross = np.cross(w, v)
        s_ratio = p.r * np.linalg.norm(cross) / speed ** 2  # |omega_perp| = |omega x v| / |v|
        c_l = 1.5 * s_ratio if s_ratio <= 0.1 else 0.09 + 0.6 * s_ratio
        lift = 0.5 * p.rho_air * area * c_l * speed ** 2 * cross / np.linalg.norm(cross) / p.m
        return np.concatenate([v, -k * speed * v - np.array([0.0, 0.0, p.g]) + lift])

    sol = solve_ivp(rhs, (0.0, times[-1]), [*position, *velocity], method="DOP853", rtol=1e-13, atol=1e-15,
                    t_eval=times)
    return sol.y[:3].T


@pytest.mark.parametrize("spin", [(0.3, -20.0, 2.0), (0.0, -3.0, 0.0)])  # S above and below the fit's knee
def test_flight_with_lift_against_scipy(spin):
    position, velocity = [-4.19, 0.05, -0.92], [4.5, -0.1, 5.8]
    times = np.linspace(0.0, 1.2, 37)
    flight = Flight(P, position, velocity, spin, lift=True)
    found = np.array([flight.position(float(t)) for t in times])
    np.testing.assert_allclose(found, _lift_reference(P, position, velocity, spin, times), atol=1e-9)


def test_backspin_lifts_the_path():
    """A free throw with backspin 20 1/s (about 3 rev/s): with lift its centre is higher at every
    time before the first impact than without; early on by the closed estimate a t^2 / 2, a the
    release's lift acceleration 1/2 rho_air A C_L v^2 / m times cos(elevation) (its upward part)."""
    release = dict(speed=7.2, angle=math.radians(52.0), backspin=20.0)
    off = shots.trace_shot(release, P)
    on = shots.trace_shot(release, P, lift=True)
    t_end = min(off["impact_time"][0] if off["impact_time"].size else np.inf,
                on["impact_time"][0] if on["impact_time"].size else np.inf, 0.9)
    times = np.linspace(0.05, t_end, 20)
    z_off = np.interp(times, off["time"], off["z"])
    z_on = np.interp(times, on["time"], on["z"])
    assert np.all(z_on > z_off)
    s_ratio = P.r * 20.0 / 7.2
    c_l = 0.09 + 0.6 * s_ratio
    a_up = 0.5 * P.rho_air * math.pi * P.r ** 2 * c_l * 7.2 ** 2 / P.m * math.cos(math.radians(52.0))
    t = 0.1
    gap = np.interp(t, on["time"], on["z"]) - np.interp(t, off["time"], off["z"])
    assert gap == pytest.approx(0.5 * a_up * t * t, rel=0.1)


def test_lift_is_opt_in_and_needs_air():
    release = dict(speed=7.2, angle=math.radians(52.0), backspin=20.0)
    assert shots.trace_shot(release, P)["z"][50] == shots.trace_shot(release, P, lift=False)["z"][50]
    with pytest.raises(ValueError, match="rho_air"):
        shots.simulate_shots(release, shots.params_for("paper"), lift=True)
    with pytest.raises(ValueError, match="`lift` must be True or False"):
        shots.simulate_shots(release, P, lift="yes")


def test_lift_graze_is_found_and_a_near_miss_is_not():
    """As the drag graze of test_shot_solver, with the lift on and backspin 20 1/s: the ring's tube
    radius set so that the closest approach of scipy's path (rtol 1e-13) to the ring's centre circle is
    rho - 1e-9 m: the first impact is on the ring there; rho + 1e-9 m: no impact there."""
    from scipy.optimize import minimize_scalar

    release = dict(speed=7.45, angle=math.radians(55.0), backspin=20.0)
    position = [-4.19, 0.0, -0.92]
    velocity = [7.45 * math.cos(release["angle"]), 0.0, 7.45 * math.sin(release["angle"])]
    times = np.linspace(0.5, 1.05, 2201)
    path = _lift_reference(P, position, velocity, (0.0, -20.0, 0.0), times)
    dist = np.hypot(np.hypot(path[:, 0], path[:, 1]) - P.R, path[:, 2])
    i = int(np.argmin(dist))
    assert 0 < i < times.size - 1

    def distance(t):
        x, y, z = _lift_reference(P, position, velocity, (0.0, -20.0, 0.0), np.array([0.0, t]))[-1]
        return math.hypot(math.hypot(x, y) - P.R, z)

    best = minimize_scalar(distance, bounds=(times[i - 1], times[i + 1]), method="bounded", options={"xatol": 1e-12})
    d_min, t_star = best.fun, best.x
    assert P.r < d_min < 0.2

    def touches(a):
        res = shots.trace_shot(release, P.replace(a=a), lift=True)
        return bool(res["impact_time"].size) and int(res["impact_kind"][0]) == 1 and \
            abs(float(res["impact_time"][0]) - t_star) < 1e-4

    assert touches(d_min - P.r + 1e-9)
    assert not touches(d_min - P.r - 1e-9)
