"""Conservative and dissipative rolling: periodic orbits, time reversal (61), energy (60)."""

import math

import numpy as np
import pytest

from rimroll.solver.analysis import boundaries, steady
from rimroll.solver.engine import outcomes
from rimroll.solver.engine.outcomes import FALL_OUT, PERIODIC_ROLLING
from rimroll.solver.engine.simulate import simulate
from rimroll.solver.physics import rolling
from rimroll.solver.physics.params import Params
from tests.helpers.bounded_runs import WEIGHT, assert_finite, mechanical_energy, sim

INF = float("inf")
ROLL = Params(mu=INF)


def energy(res, p):
    return rolling.energy.py_func(res["beta_end"], res["omega1_end"], res["omega2_end"], res["omega3_end"],
                                  p.as_array())


@pytest.mark.parametrize("beta0,omega30", [(1.2, 10.0), (1.0, 10.0), (0.5, 30.0)])
def test_small_oscillations_have_the_linear_half_period(beta0, omega30):
    """Near a stable steady motion (h < 0) the half period tends to pi / sqrt(-h) (54)."""
    h = steady.stability(beta0, omega30, ROLL)
    assert h < 0
    x = steady.steady_state(beta0, omega30, ROLL)
    errors = []
    for eps in (1e-2, 1e-3):
        y = x.copy()
        y[1] = eps
        res = simulate(y, ROLL, rtol=1e-10, atol=1e-12)
        assert res["outcome"] == PERIODIC_ROLLING and res["status"] == 0
        errors.append(abs(res["half_period"] / (math.pi / math.sqrt(-h)) - 1))
    assert errors[1] < 1e-6
    assert errors[1] < errors[0] / 30  # the error is O(amplitude^2)


def test_revolutions_match_a_scipy_quadrature_of_alpha():
    """revolutions = alpha(t_end) / 2 pi with alpha_dot = -r omega3 / (R - rho cos beta) (19)."""
    from scipy.integrate import solve_ivp

    p = Params(mu=INF, k_r=0.02)
    a = p.as_array()
    x = steady.steady_state(1.2, 10.0, p)
    x[1] = 0.5
    res = simulate(x, p, t_max=1.5, rtol=1e-10, atol=1e-12)
    assert res["t_end"] == 1.5

    def fun(t, y):
        rates = rolling.rolling_rhs.py_func(*y[:4], a)
        return [*rates, -p.r * y[3] / (p.R - p.rho * math.cos(y[0]))]

    sol = solve_ivp(fun, (0, 1.5), [*x, 0.0], method="DOP853", rtol=1e-12, atol=1e-12)
    assert res["revolutions"] == pytest.approx(sol.y[4, -1] / (2 * math.pi), rel=1e-8)
    assert res["revolutions"] < 0  # omega3 > 0 circulates in the -alpha direction


def test_time_reversal_symmetry():
    """(61): the state dt after x equals the omega1-flipped state dt before it."""
    x = steady.steady_state(1.2, 10.0, ROLL)
    x[1] = 0.7
    dt = 0.15
    fwd = simulate(x, ROLL, t_max=dt, rtol=1e-11, atol=1e-13)
    assert fwd["t_end"] == dt and fwd["status"] == 0
    flipped = np.array([fwd["beta_end"], -fwd["omega1_end"], fwd["omega2_end"], fwd["omega3_end"]])
    back = simulate(flipped, ROLL, t_max=dt, rtol=1e-11, atol=1e-13)
    end = np.array([back["beta_end"], -back["omega1_end"], back["omega2_end"], back["omega3_end"]])
    np.testing.assert_allclose(end, x, rtol=0, atol=1e-8)


@pytest.mark.parametrize("rtol", [1e-6, 1e-8, 1e-10])
def test_energy_drift_bounded_by_rtol(rtol):
    x = steady.steady_state(np.array([1.0, 1.1, 1.2]), 10.0, ROLL)
    x[:, 1] = [1.0, -0.5, 1.0]
    res = simulate(x, ROLL, t_max=20.0, rtol=rtol, atol=rtol * 1e-2, method="dp5")  # a Runge-Kutta path's drift
    assert np.all(res["outcome"] == PERIODIC_ROLLING)
    assert np.all(res["energy_drift"] < 10 * rtol)
    assert np.allclose(np.abs(energy(res, ROLL) - rolling.energy.py_func(*x.T, ROLL.as_array())),
                       res["energy_drift"] * np.abs(rolling.energy.py_func(*x.T, ROLL.as_array())), rtol=1e-6)


@pytest.mark.parametrize("k_r,k_d", [(0.02, 0.0), (0.0, 0.02)])
def test_dissipation_removes_energy_and_periodic_orbits(k_r, k_d):
    p = Params(mu=INF, k_r=k_r, k_d=k_d)
    x = steady.steady_state(1.2, 10.0, p)
    x[1] = 1.0
    e0 = rolling.energy.py_func(*x, p.as_array())
    energies = []
    for t_max in (0.5, 1.0, 2.0, 4.0):
        res = simulate(x, p, t_max=t_max)
        assert res["outcome"] != PERIODIC_ROLLING
        if res["t_end"] == t_max:
            energies.append(energy(res, p))
    assert len(energies) >= 2
    assert np.all(np.diff([e0, *energies]) < 0)
    # a conservative periodic state is not periodic once dissipation is on
    assert simulate(x, ROLL)["outcome"] == PERIODIC_ROLLING


def test_dissipative_runs_to_a_fall_or_t_max():
    p = Params(mu=INF, k_d=0.02)
    x = steady.steady_state(1.2, 10.0, p)
    x[1] = 1.0
    res = simulate(x, p, t_max=200.0)
    assert res["outcome"] <= FALL_OUT and 0 < res["t_end"] < 200.0  # drilling resistance: falls out
    assert res["status"] == 0


def test_vanishing_dissipation_approaches_the_conservative_outcomes():
    rng = np.random.default_rng(4)
    n = 80
    x = np.stack([rng.uniform(0.8, 1.8, n), rng.uniform(-20, 20, n), rng.choice([35.0, 65.0], n), np.full(n, 10.0)], -1)
    cons = simulate(x, ROLL, t_max=10.0)
    falls = cons["outcome"] <= FALL_OUT
    assert falls.sum() > 20
    for k in ({"k_r": 1e-7}, {"k_d": 1e-7}):
        dis = simulate(x, Params(mu=INF, **k), t_max=10.0)
        np.testing.assert_array_equal(dis["outcome"][falls], cons["outcome"][falls])
        np.testing.assert_allclose(dis["t_end"][falls], cons["t_end"][falls], rtol=1e-4)


@pytest.fixture(scope="module")
def separatrix():
    """omega1* of the separatrix boundary of Fig. 11's periodic region at beta = 1.0601
    (rolling only), bracketed by bisection to ~1e-14 1/s."""
    ref = boundaries.refine([1.0601, 2.773, 35.0, 10.0], [1.0601, 2.975, 35.0, 10.0], ROLL, n_bisect=45,
                            method="dp5")  # the integrator's own boundary: the test below runs dp5 at 1e-13 from it
    assert ref["type"] == boundaries.SEPARATRIX
    return ref["periodic"][1], ref["other"][1]


def test_next_to_a_separatrix_runs_end_in_bounded_work(separatrix):
    """Approaching the separatrix the half period grows like -ln(distance)/lambda (a saddle's
    homoclinic orbit); the runs end (periodic inside, a fall outside) without crawling."""
    w_in, w_out = separatrix
    d = np.array([1e-4, 1e-7, 1e-10, 1e-13])
    inside = np.stack([np.full(4, 1.0601), w_in - d, np.full(4, 35.0), np.full(4, 10.0)], -1)
    outside = inside.copy()
    outside[:, 1] = w_out + d
    r_in = sim(inside, ROLL, t_max=20.0, max_steps=20_000, method="dp5")  # the integrator's steps
    r_out = sim(outside, ROLL, t_max=20.0, max_steps=20_000, method="dp5")
    for r in (r_in, r_out):
        assert (r["status"] == outcomes.OK).all()
        assert_finite(r)
        assert (r["n_steps"] < 1000).all(), r["n_steps"]  # ~100-200 steps; a crawl would be >> 1e3
    assert (r_in["outcome"] == outcomes.PERIODIC_ROLLING).all()
    assert np.isin(r_out["outcome"], (outcomes.FALL_IN, outcomes.FALL_OUT)).all()
    hp = r_in["half_period"]
    steps = np.diff(hp)  # one step per 1e3 in distance
    assert (steps > 0).all()
    assert np.ptp(steps) < 0.1 * steps.mean()  # logarithmic growth: equal increments per decade
    assert (r_in["f2_min"] > 0.5 * WEIGHT).all()  # F2_min does not go to 0: separatrix, not deadlock


@pytest.mark.parametrize("k", [{"k_r": 0.02}, {"k_d": 0.02}])
def test_long_dissipative_run_loses_energy_monotonically(k):
    """t_max = 600 s with rolling or drilling resistance from Fig. 11's stable steady motion
    (rolling only; k = 0.02 1/s makes it fall after ~10-20 s): the energy at t_end never
    increases with t_max, ends below E0, and the 600 s run ends by the rules (status ok)."""
    from rimroll.workflows.outcome_grids import steady_beta0

    p = ROLL.replace(**k)
    b0 = steady_beta0(35.0, 10.0, p, 0.8, 1.8)
    x0 = np.array([b0, 0.1, 35.0, 10.0])
    t_max = np.array([2.5, 5.0, 7.5, 600.0])
    energies, t_end = [], []
    for t in t_max:
        r = sim(x0, p, t_max=float(t), max_steps=2_000_000)
        assert r["status"][0] == outcomes.OK
        assert_finite(r)
        energies.append(mechanical_energy(r["beta_end"][0], r["omega1_end"][0], r["omega2_end"][0], r["omega3_end"][0],
                                          p))
        t_end.append(r["t_end"][0])
    e0 = mechanical_energy(*x0, p)
    energies = np.array(energies)
    assert (np.diff(energies) <= 1e-9 * e0).all(), energies
    assert energies[-1] < e0 and energies[2] < energies[0] < e0
    assert t_end[:3] == pytest.approx(t_max[:3])  # still on the rim at the short t_max
    assert 7.5 < t_end[3] <= 600.0
