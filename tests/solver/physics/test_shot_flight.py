"""The shot's flight (solver.physics.shot_flight) against the closed form in vacuum and scipy with drag."""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy.integrate import solve_ivp

from rimroll.solver import shots
from rimroll.solver.physics.shot_flight import Flight

P = shots.params_for("paper")
G = P.g


def _drag_reference(p, position, velocity, times):
    """Centre positions [m] at ``times`` from scipy (DOP853, rtol 1e-13) with the drag -k |v| v - g z."""
    k = 0.5 * p.rho_air * p.C_D * math.pi * p.r ** 2 / p.m

    def rhs(_, s):
        v = s[3:]
        return np.concatenate([v, -k * np.linalg.norm(v) * v - np.array([0.0, 0.0, p.g])])

    sol = solve_ivp(rhs, (0.0, times[-1]), [*position, *velocity], method="DOP853", rtol=1e-13, atol=1e-15,
                    t_eval=times)
    return sol.y[:3].T


def test_trace_before_the_first_impact_is_the_vacuum_parabola():
    """A 3-D release (lateral offset, azimuth, spin): the traced centre follows
    p0 + v0 t - g t^2 z / 2 with v0 = v (cos e cos az, cos e sin az, sin e) up to its first impact."""
    release = dict(speed=7.3, angle=math.radians(50.0), distance=4.19, height=0.92, lateral=0.1,
                   azimuth=-0.02, backspin=20.0, sidespin=3.0)
    res = shots.trace_shot(release, P, shots.Contact())
    t = res["time"]
    before = t < (res["impact_time"][0] if res["impact_time"].size else np.inf)
    v, el, az = release["speed"], release["angle"], release["azimuth"]
    np.testing.assert_allclose(res["x"][before], -4.19 + v * math.cos(el) * math.cos(az) * t[before], atol=1e-12)
    np.testing.assert_allclose(res["y"][before], 0.1 + v * math.cos(el) * math.sin(az) * t[before], atol=1e-12)
    np.testing.assert_allclose(res["z"][before], -0.92 + v * math.sin(el) * t[before] - 0.5 * G * t[before] ** 2,
                               atol=1e-12)


def test_flight_with_drag_against_scipy():
    """rho_air = 1.2: the RK4/Hermite flight agrees with scipy's DOP853 at rtol 1e-13 to 1e-9 m over 1.2 s,
    at step ends and between them."""
    p = P.replace(rho_air=1.2)
    position, velocity = [-4.19, 0.05, -0.92], [4.5, -0.1, 5.8]
    times = np.linspace(0.0, 1.2, 37)
    flight = Flight(p, position, velocity)
    found = np.array([flight.position(float(t)) for t in times])
    np.testing.assert_allclose(found, _drag_reference(p, position, velocity, times), atol=1e-9)


def test_speed_to_reach_with_drag_passes_through_the_hoop():
    """With drag the shooting speed's path, integrated by scipy, passes within 1e-8 m of the hoop's
    centre; drag needs more speed than vacuum."""
    p = P.replace(rho_air=1.2)
    theta = math.radians(52.0)
    v = shots.speed_to_reach(theta, 4.19, 0.92, p)
    assert v > shots.speed_to_reach(theta, 4.19, 0.92, P)
    k = 0.5 * p.rho_air * p.C_D * math.pi * p.r ** 2 / p.m

    def rhs(_, s):
        vel = s[3:]
        return np.concatenate([vel, -k * np.linalg.norm(vel) * vel - np.array([0.0, 0.0, p.g])])

    def at_axis(_, s):
        return s[0]

    at_axis.terminal = True
    sol = solve_ivp(rhs, (0.0, 5.0), [-4.19, 0.0, -0.92, v * math.cos(theta), 0.0, v * math.sin(theta)],
                    method="DOP853", rtol=1e-13, atol=1e-15, events=at_axis)
    assert abs(sol.y_events[0][0][2]) < 1e-8


def test_speed_to_reach_closed_form_and_unreachable():
    """Vacuum: v^2 = g L^2 / (2 cos^2 theta (L tan theta - h)); NaN where L tan theta <= h."""
    theta = math.radians(55.0)
    v = shots.speed_to_reach(theta, 4.19, 0.92, P)
    x_t = 4.19 / (v * math.cos(theta))
    assert -0.92 + v * math.sin(theta) * x_t - 0.5 * G * x_t ** 2 == pytest.approx(0.0, abs=1e-12)
    assert math.isnan(shots.speed_to_reach(math.atan(0.92 / 4.19), 4.19, 0.92, P))
