"""Hybrid (finite mu) scenes: rolling/slipping switching of paper Sect. 5.2.2."""

import numpy as np
import pytest
from scipy.optimize import brentq

from rimroll.solver.analysis import steady
from rimroll.solver.engine import outcomes
from rimroll.solver.engine.outcomes import PERIODIC_ROLLING
from rimroll.solver.engine.simulate import simulate
from rimroll.solver.physics import rolling, slipping, switching
from rimroll.solver.physics.params import Params
from tests.helpers.bounded_runs import P, assert_finite, sim

INF = float("inf")


def fig11_states(n, seed):
    rng = np.random.default_rng(seed)
    return np.stack([rng.uniform(0.8, 1.8, n), rng.uniform(-20, 20, n), rng.choice([35.0, 65.0, 105.0], n),
                     np.full(n, 10.0)], axis=-1)


def test_huge_mu_gives_the_rolling_only_outcomes():
    x = fig11_states(150, seed=21)
    hyb = simulate(x, Params(mu=1e8), t_max=10.0)
    rol = simulate(x, Params(mu=INF), t_max=10.0)
    ok = hyb["status"] == 0
    # mu = 1e8 only slips within ~|F_t|/mu of separation, where the slip test is ill-conditioned;
    # a lane may then chatter into max_switches, reported in status
    assert ok.mean() >= 0.98
    np.testing.assert_array_equal(hyb["outcome"][ok], rol["outcome"][ok])
    np.testing.assert_allclose(hyb["t_end"][ok], rol["t_end"][ok], rtol=1e-4)


def test_periodic_rolling_without_slip_is_unchanged_by_finite_mu():
    p = Params(mu=1.0)
    assert steady.required_friction(1.2, 10.0, p) < 1.0
    x = steady.steady_state(1.2, 10.0, p)
    x[1] = 0.5
    hyb = simulate(x, p)
    rol = simulate(x, Params(mu=INF), method="dp5")  # the rolling-only kernel, integrated as the hybrid one is
    assert hyb["outcome"] == rol["outcome"] == PERIODIC_ROLLING
    assert hyb["slip_phases"] == 0 and hyb["slip_time"] == 0.0
    assert hyb["half_period"] == rol["half_period"]


def test_outside_the_friction_cone_slips_at_t0():
    p = Params(mu=0.2)
    x = np.array([1.2, 0.5, 35.0, 10.0])
    pa = p.as_array()
    assert rolling.friction_margin.py_func(*x, pa) < 0 < rolling.normal_force.py_func(x[0], x[1], x[3], pa)
    res = simulate(x, p, t_max=2.0)
    assert res["slip_phases"] >= 1 and res["slip_time"] > 0 and res["status"] == 0


def boundary_omega1(p, beta=1.2, omega2=35.0, omega3=10.0):
    a = p.as_array()
    return brentq(lambda w: rolling.friction_margin.py_func(beta, w, omega2, omega3, a), 0.0, 10.0, xtol=1e-15)


def test_state_on_the_slip_boundary_does_not_chatter():
    p = Params(mu=1.0)
    w = boundary_omega1(p)
    for w1 in (np.nextafter(w, 0), w, np.nextafter(w, 20)):
        res = simulate([1.2, w1, 35.0, 10.0], p, t_max=10.0)
        assert res["status"] == 0
        assert 1 <= res["slip_phases"] <= 3
        assert res["t_end"] == 10.0 or res["outcome"] <= 1


def test_slipping_never_creates_energy():
    x = fig11_states(60, seed=22)
    p = Params(mu=1.0)
    res = simulate(x, p, t_max=5.0, rtol=1e-10, atol=1e-12)
    a = p.as_array()
    e0 = rolling.energy.py_func(*x.T, a)
    slipped = res["slip_phases"] > 0
    assert slipped.sum() > 10
    # energy_drift is |E(t_end) - E0| / max(|E0|, m g rho): in conservative hybrid runs the energy lost
    rolled_back = slipped & (res["slip_time"] < res["t_end"])
    e1 = rolling.energy.py_func(res["beta_end"], res["omega1_end"], res["omega2_end"], res["omega3_end"], a)
    on_rim_rolling = rolled_back & (res["outcome"] == 3)
    assert np.all(e1[on_rim_rolling] <= e0[on_rim_rolling] * (1 + 1e-9))
    assert np.all(res["energy_drift"][~slipped & (res["t_end"] > 0)] < 1e-7)


@pytest.mark.parametrize("key", ["delta", "u_stop", "phi_tol", "u_floor", "dt_max"])
def test_halving_or_doubling_switching_tolerances_changes_no_outcome(key):
    x = fig11_states(80, seed=23)
    p = Params(mu=1.0)
    base = simulate(x, p, t_max=5.0)
    tight = simulate(x, p, t_max=5.0, rtol=1e-10, atol=1e-12)
    away = base["outcome"] == tight["outcome"]  # away from rtol-sensitive boundaries
    assert (base["slip_phases"] > 0).sum() > 20
    default = switching.default_tolerances()[["delta", "u_stop", "phi_tol", "u_floor", "dt_max"].index(key)]
    for factor in (0.5, 2.0):
        res = simulate(x, p, t_max=5.0, switching={key: default * factor})
        np.testing.assert_array_equal(res["outcome"][away], base["outcome"][away])
        np.testing.assert_allclose(res["t_end"][away], base["t_end"][away], rtol=1e-3)


# ------------------------------------------------------------------------- transition maps


def test_enter_slipping_starts_along_the_repelling_limit_direction():
    p = Params(mu=1.0)
    a = p.as_array()
    sw = switching.default_tolerances()
    w = boundary_omega1(p) + 0.1  # just outside the cone
    y = np.zeros(7)
    y[:5] = [1.2, w, 35.0, 10.0, 0.3]
    before = y.copy()
    switching.enter_slipping(y, a, sw)
    phi1 = slipping.limit_direction.py_func(1.2, w, 35.0, 10.0, a)
    delta = sw[switching.SW_DELTA]
    assert np.hypot(y[4], y[5]) == pytest.approx(delta, rel=1e-12)
    assert np.arctan2(y[5], y[4]) == pytest.approx(phi1, abs=1e-12)
    assert y[6] == 0.3  # alpha moved to the last slot
    # launched by the contact impulse J = j m delta e(phi1) / (1 + j): the centre's velocity
    # changes by J / m, beta is untouched, and the energy only by (1/2) j m delta^2 / (1 + j)
    r, j, m = p.r, p.j, p.m
    v_before = np.array([-r * before[3], r * before[1]])  # (V1, V3) while rolling
    v_after = np.array([y[4] - r * y[3], y[5] + r * y[1]])
    np.testing.assert_allclose(v_after - v_before, j * delta / (1 + j) * np.array([np.cos(phi1), np.sin(phi1)]),
                               rtol=1e-9, atol=1e-15)
    assert y[0] == before[0] and y[2] == before[2]
    e0 = rolling.energy.py_func(*before[:4], a)
    e1 = slipping.energy.py_func(*y[:6], a)
    assert e1 - e0 == pytest.approx(0.5 * j * m * delta**2 / (1 + j), rel=1e-3)
    # phi1 repels (u grows) exactly when the friction margin is negative
    rate = slipping.radial_slip_rate.py_func(1.2, w, 35.0, 10.0, phi1, a)
    assert rate > 0
    assert switching._rate_phi1(before, a) == pytest.approx(rate, rel=1e-9)


def test_return_along_phi2_extrapolates_the_remaining_time():
    p = Params(mu=1.0)
    a = p.as_array()
    sw = switching.default_tolerances()
    x = [1.2, 2.0, 35.0, 10.0]
    phi2 = slipping.limit_direction.py_func(*x, a) + np.pi
    rate = slipping.radial_slip_rate.py_func(*x, phi2, a)
    assert rate < 0  # phi2 always attracts
    u = 0.5 * sw[switching.SW_U_STOP]
    y = np.array([*x, u * np.cos(phi2), u * np.sin(phi2), 0.7])
    out = np.zeros(7)
    dt = switching.try_return(y, a, sw, 1.0, out)
    assert dt == pytest.approx(u / -rate, rel=1e-12)
    assert out[4] == pytest.approx(0.7, abs=1e-6)  # alpha back in the rolling slot (plus dt alpha_dot)
    rates = np.array(slipping.slipping_rhs.py_func(*y[:6], a))[:4]  # one Euler step of (42)
    np.testing.assert_allclose(out[:4], np.array(x) + dt * rates, rtol=1e-14)
    # too large a slip speed, or a direction far from both limit directions: no return
    y2 = y.copy()
    y2[4:6] *= 4.0
    assert switching.try_return(y2, a, sw, 1.0, out) == -1.0
    y3 = np.array([*x, u * np.cos(phi2 + 0.5), u * np.sin(phi2 + 0.5), 0.7])
    assert switching.try_return(y3, a, sw, 1.0, out) == -1.0


@pytest.mark.parametrize("factor", [1 - 1e-9, 1.0, 1 + 1e-9])
def test_slip_roll_switching_on_the_friction_cone_does_not_hang(factor):
    """A steady motion whose required friction (56) equals mu to 1e-9, nudged: at most a bounded
    number of switches, status ok or too_many_switches, no NaN, within the step budget."""
    b0, w30 = 1.0, 10.0
    mu = float(steady.required_friction(b0, w30, P)) * factor
    p = P.replace(mu=mu)
    x = steady.steady_state(b0, w30, p)
    states = np.array([x, x + [0, 1e-6, 0, 0], x + [1e-6, 0, 0, 0]])
    r = sim(states, p, t_max=5.0, max_steps=200_000, max_switches=2000)
    assert np.isin(r["status"], (outcomes.OK, outcomes.TOO_MANY_SWITCHES)).all(), r["status"]
    assert_finite(r)
    assert (r["slip_phases"] <= 2000).all()


def test_chattering_state_of_the_fig12_slipping_scene_ends():
    """States of Fig. 12's slipping scene that slip again and again (~70 slip phases in 20 s)."""
    states = [[1.1672, 0.05, 65.0, 10.0], [1.1712, -0.5, 65.0, 10.0]]
    r = sim(states, P, t_max=20.0, max_steps=500_000, max_switches=10_000)
    assert np.isin(r["status"], (outcomes.OK, outcomes.TOO_MANY_SWITCHES)).all()
    assert_finite(r)
    assert (r["n_steps"] < 500_000).all()
