"""Equations of motion: energy (60), dissipation (83), phase consistency at u = 0, limit directions (75)-(81)."""

import numpy as np
import pytest
from scipy.integrate import solve_ivp
from scipy.optimize import brentq

from rimroll import solver
from rimroll.solver.analysis import steady
from rimroll.solver.physics import kinematics, rolling, slipping
from tests.helpers.finite_differences import gradient

RNG = np.random.default_rng(20261122)


def random_rolling_states(n):
    return np.column_stack(
        [RNG.uniform(0.2, 2.0, n), RNG.uniform(-15, 15, n), RNG.uniform(-80, 80, n), RNG.uniform(-20, 20, n)]
    )


def rolling_ode(p):
    pa = p.as_array()
    return lambda t, x: np.array(rolling.rolling_rhs(x[0], x[1], x[2], x[3], pa))


def test_energy_60_with_rho_is_conserved_by_rolling_trajectories():
    p = solver.Params(mu=np.inf)
    pa = p.as_array()
    x0 = steady.steady_state(1.2, 10.0, p)
    x0[1] = 3.0  # a sizeable oscillation about the steady motion
    sol = solve_ivp(rolling_ode(p), (0, 5.0), x0, method="DOP853", rtol=1e-12, atol=1e-12, dense_output=True)
    xs = sol.sol(np.linspace(0, 5.0, 400))
    E = rolling.energy(xs[0], xs[1], xs[2], xs[3], pa)
    assert np.ptp(xs[0]) > 0.05  # beta really moves, so the potential term is exercised
    assert np.max(np.abs(E - E[0])) / abs(E[0]) < 1e-10
    # The printed (60), potential m g r sin(beta), is NOT conserved (the equations conserve
    # m g rho sin(beta)): the check can fail.
    printed = E - p.m * p.g * (p.rho - p.r) * np.sin(xs[0])
    assert np.max(np.abs(printed - printed[0])) / abs(printed[0]) > 1e-4


def test_energy_decreases_at_the_rate_of_the_contact_moment():
    p = solver.Params(k_r=0.05, k_d=0.08)
    pa = p.as_array()
    x0 = steady.steady_state(1.2, 10.0, p)
    x0[1] = 2.0

    def augmented(t, y):  # rolling state + the integral of the dissipated power
        return [*rolling.rolling_rhs(y[0], y[1], y[2], y[3], pa), rolling.dissipated_power(y[1], y[2], y[3], pa)]

    sol = solve_ivp(augmented, (0, 4.0), [*x0, 0.0], method="DOP853", rtol=1e-12, atol=1e-12, dense_output=True)
    ys = sol.sol(np.linspace(0, 4.0, 200))
    E = rolling.energy(ys[0], ys[1], ys[2], ys[3], pa)
    assert np.all(np.diff(E) < 0)
    assert E[0] - E[-1] > 1e-3 * abs(E[0])
    np.testing.assert_allclose(E - E[0], ys[4], atol=1e-9 * abs(E[0]))


@pytest.mark.parametrize("k_r, k_d", [(0.0, 0.0), (0.02, 0.0), (0.0, 0.02), (0.3, 0.7)])
def test_energy_rate_equals_dissipated_power_pointwise(k_r, k_d):
    pa = solver.Params(k_r=k_r, k_d=k_d).as_array()
    for x in random_rolling_states(20):
        rates = np.array(rolling.rolling_rhs(*x, pa))
        grad = gradient(lambda z: rolling.energy(*z, pa), x)
        power = rolling.dissipated_power(x[1], x[2], x[3], pa)
        assert grad @ rates == pytest.approx(power, abs=1e-6 * np.abs(grad * rates).max())


@pytest.mark.parametrize("k_r, k_d", [(0.0, 0.0), (0.3, 0.7)])
def test_contact_force_and_friction_margin_rates_are_their_time_derivatives(k_r, k_d):
    """The analytic rates of (F1, F2, F3) and of the margin (39), which the slip-onset gate bounds the
    margin with, equal the derivatives of the forces along the rolling rates (central differences)."""
    pa = solver.Params(mu=0.8, k_r=k_r, k_d=k_d).as_array()
    for x in random_rolling_states(20):
        rates = np.array(rolling.rolling_rhs(*x, pa))
        for i in range(3):
            grad = gradient(lambda z, i=i: rolling.contact_forces(*z, pa)[i], x)
            dF = rolling.contact_forces_rate(*x, *rates, pa)[i]
            assert dF == pytest.approx(grad @ rates, abs=1e-6 * np.abs(grad * rates).max() + 1e-9)
        grad = gradient(lambda z: rolling.friction_margin(*z, pa), x)
        rate = rolling.friction_margin_rate(*x, *rates, pa)
        assert rate == pytest.approx(grad @ rates, abs=1e-6 * np.abs(grad * rates).max() + 1e-9)


@pytest.mark.parametrize("k_r, k_d", [(0.0, 0.0), (0.02, 0.0), (0.0, 0.02), (0.3, 0.7)])
def test_slipping_equations_with_rolling_force_reproduce_rolling(k_r, k_d):
    pa = solver.Params(k_r=k_r, k_d=k_d).as_array()
    for x in random_rolling_states(25):
        F1, F2, F3 = rolling.contact_forces(*x, pa)
        rates = slipping.newton_euler_rates(*x, 0.0, 0.0, F1, F3, pa)
        np.testing.assert_allclose(rates[:4], rolling.rolling_rhs(*x, pa), rtol=1e-12, atol=1e-10)
        assert abs(rates[4]) < 1e-10 and abs(rates[5]) < 1e-10  # the constraint u_dot = 0 holds
        assert slipping.slipping_normal_force(x[0], x[1], x[3], 0.0, 0.0, pa) == pytest.approx(F2, rel=1e-13)


def paper_42(y, p):
    """(41)-(42) transcribed from the paper (alpha_dot restored in front of the first column)."""
    beta, w1, w2, w3, u1, u3 = y
    r, rho, R, j, m, g, mu = p.r, p.rho, p.R, p.j, p.m, p.g, p.mu
    s, c = np.sin(beta), np.cos(beta)
    ad = (u1 - r * w3) / (R - rho * c)
    bd = (u3 + r * w1) / rho
    F2 = m * (u1 - r * w3) ** 2 * c / (R - rho * c) - m * (u3 + r * w1) ** 2 / rho + m * g * s
    un = np.hypot(u1, u3)
    k = mu * F2 / (m * r * j)
    return np.array([
        bd,
        ad * (-w3 * s + w2 * c) + k * u3 / un,
        ad * (-w1 * c) + bd * w3,
        ad * (w1 * s) - bd * w2 - k * u1 / un,
        ad * (-u3 * s) - bd * r * w2 - k * r * (1 + j) * u1 / un,
        ad * (-r * w2 * c + u1 * s) - k * r * (1 + j) * u3 / un - g * c,
    ])


def test_slipping_rhs_matches_the_papers_42():
    p = solver.Params(mu=0.7)
    pa = p.as_array()
    for x in random_rolling_states(25):
        y = np.concatenate([x, RNG.uniform(-0.5, 0.5, 2)])
        np.testing.assert_allclose(slipping.slipping_rhs(*y, pa), paper_42(y, p), rtol=1e-11, atol=1e-9)


@pytest.mark.parametrize("kw", [dict(mu=1.0), dict(mu=0.7, k_r=0.3, k_d=0.7), dict(mu=1e9)])
def test_slipping_jacobian_is_the_derivative_of_42(kw):
    """The hand-differentiated Jacobian against complex-step derivatives of (42) and (19) (exact to
    rounding: no subtraction), on states with slip speeds from 1e-6 to 1 m/s."""
    pa = solver.Params(**kw).as_array()

    def rates(z):
        return np.array([*slipping.slipping_rhs.py_func(*z, pa), kinematics.alpha_rate.py_func(z[0], z[3], z[4], pa)])

    for x in random_rolling_states(20):
        y = np.concatenate([x, RNG.normal(0.0, 1.0, 2) * 10.0 ** RNG.uniform(-6, 0)])
        J = np.zeros((7, 7))
        slipping.slipping_jacobian(*y, pa, J)
        J_cs = np.zeros((7, 7))
        for k in range(6):
            z = y.astype(complex)
            z[k] += 1e-30j
            J_cs[:, k] = np.imag(rates(z)) / 1e-30
        np.testing.assert_allclose(J, J_cs, rtol=1e-9, atol=1e-12 * np.abs(J_cs).max())


def test_directional_limits_76_are_the_limits_of_42():
    p = solver.Params(mu=0.8)
    pa = p.as_array()
    for x in random_rolling_states(10):
        B1, B3, C = slipping.directional_limits(*x, pa)
        # (76) as printed
        r, rho, R, j = p.r, p.rho, p.R, p.j
        cb = np.cos(x[0])
        assert B1 == pytest.approx(-r**2 * x[1] * x[2] / rho, rel=1e-12)
        assert B3 == pytest.approx(r**2 * x[2] * x[3] * cb / (R - rho * cb) - p.g * cb, rel=1e-12, abs=1e-12)
        F2 = rolling.normal_force(x[0], x[1], x[3], pa)
        assert C == pytest.approx(p.mu * (1 + j) / j * F2 / p.m, rel=1e-12)
        for phi in np.linspace(0, 2 * np.pi, 7):  # (75): the limit of u_dot from direction phi
            d = 1e-9
            rates = slipping.slipping_rhs(*x, d * np.cos(phi), d * np.sin(phi), pa)
            np.testing.assert_allclose(rates[4:], [B1 - C * np.cos(phi), B3 - C * np.sin(phi)],
                                       atol=1e-5 * (abs(C) + np.hypot(B1, B3)))


@pytest.mark.parametrize("k_r, k_d", [(0.0, 0.0), (0.05, 0.05)])
def test_phi1_switches_from_attracting_to_repelling_on_the_slip_boundary(k_r, k_d):
    """Sect. 5.2.1: the boundary between attracting and repelling phi1 is the slip condition (39)."""
    pa = solver.Params(mu=1.0, k_r=k_r, k_d=k_d).as_array()
    w2, w3 = 35.0, 10.0
    beta = 1.3
    # walk omega1 outward from a rolling state until the friction cone (39) is left
    def margin(w1):
        return rolling.friction_margin(beta, w1, w2, w3, pa)
    assert margin(0.0) > 0 and margin(12.0) < 0
    w1_star = brentq(margin, 0.0, 12.0, xtol=1e-13)
    for w1, expect_repelling in ((w1_star - 1e-4, False), (w1_star + 1e-4, True)):
        phi1 = slipping.limit_direction(beta, w1, w2, w3, pa)
        ud1 = slipping.radial_slip_rate(beta, w1, w2, w3, phi1, pa)
        ud2 = slipping.radial_slip_rate(beta, w1, w2, w3, phi1 + np.pi, pa)
        assert (ud1 > 0) == expect_repelling
        assert ud2 < 0  # phi2 is always attracting while F2 > 0
    phi_star = slipping.limit_direction(beta, w1_star, w2, w3, pa)
    assert abs(slipping.radial_slip_rate(beta, w1_star, w2, w3, phi_star, pa)) < 1e-8


def test_slipping_energy_decays_at_the_friction_power():
    p = solver.Params(mu=0.5)
    pa = p.as_array()
    for x in random_rolling_states(10):
        y = np.concatenate([x, RNG.uniform(-0.3, 0.3, 2)])
        rates = np.array(slipping.slipping_rhs(*y, pa))
        grad = gradient(lambda z: slipping.energy(*z, pa), y)
        F2 = slipping.slipping_normal_force(y[0], y[1], y[3], y[4], y[5], pa)
        power = -p.mu * F2 * np.hypot(y[4], y[5])  # F_C . v_C
        assert grad @ rates == pytest.approx(power, abs=1e-6 * np.abs(grad * rates).max())


def test_rolling_field_has_the_time_reversal_symmetry():
    """omega1 -> -omega1 reverses the flow (Sect. 4.1): beta_dot, omega2_dot, omega3_dot odd, omega1_dot even."""
    pa = solver.Params().as_array()
    for x in random_rolling_states(20):
        f = np.array(rolling.rolling_rhs(*x, pa))
        g = np.array(rolling.rolling_rhs(x[0], -x[1], x[2], x[3], pa))
        np.testing.assert_allclose(g, [-f[0], f[1], -f[2], -f[3]], rtol=1e-13, atol=1e-12)


def test_centre_velocity_is_the_derivative_of_the_centre_position():
    p = solver.Params()
    pa = p.as_array()
    beta, w1, w3, u1, u3 = 0.9, 4.0, 10.0, 0.2, -0.1
    _, beta_dot = kinematics.angle_rates(beta, w1, w3, u1, u3, pa)
    h = 1e-7
    (d_p, z_p), (d_m, z_m) = kinematics.centre_position(beta + h, pa), kinematics.centre_position(beta - h, pa)
    v_rad, v_vert, v_tan = kinematics.centre_velocity(beta, w1, w3, u1, u3, pa)
    assert v_rad == pytest.approx((d_p - d_m) / (2 * h) * beta_dot, rel=1e-7)
    assert v_vert == pytest.approx((z_p - z_m) / (2 * h) * beta_dot, rel=1e-7)
    assert v_tan == pytest.approx(u1 - p.r * w3)
