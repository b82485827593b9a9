"""Steady motions and their limits (paper Sect. 3), checked against the paper's numbers."""

import numpy as np
import pytest

from rimroll import solver
from rimroll.solver._jit import vectorised
from rimroll.solver.analysis import steady
from rimroll.solver.physics import rolling

P = solver.Params()
rhs = vectorised(rolling.rolling_rhs)

# A spread of non-trivial steady motions over the four branches (away from singular lines).
STEADY_POINTS = [(1.2, 10.0), (0.6, 25.0), (-0.4, 40.0), (2.0, -8.0), (0.3, -15.0), (1.45, 3.0)]


def jacobian(x, p, eps=1e-6):
    """Central finite-difference Jacobian of the compiled rolling right-hand side."""
    pa = p.as_array()
    J = np.empty((4, 4))
    for k in range(4):
        h = eps * max(1.0, abs(x[k]))
        xp, xm = np.array(x, float), np.array(x, float)
        xp[k] += h
        xm[k] -= h
        J[:, k] = (np.array(rolling.rolling_rhs(*xp, pa)) - np.array(rolling.rolling_rhs(*xm, pa))) / (2 * h)
    return J


@pytest.mark.parametrize("beta0, omega30", STEADY_POINTS)
def test_steady_motion_is_an_equilibrium_of_the_compiled_rhs(beta0, omega30):
    x0 = steady.steady_state(beta0, omega30, P)
    rates = np.array(rolling.rolling_rhs(*x0, P.as_array()))
    scale = abs(x0[2]) * abs(omega30) + P.g / P.r
    assert np.all(np.abs(rates) <= 1e-12 * scale)


@pytest.mark.parametrize("beta0, omega30", STEADY_POINTS)
def test_linearisation_eigenvalues_are_0_0_and_pm_sqrt_h(beta0, omega30):
    x0 = steady.steady_state(beta0, omega30, P)
    ev = np.linalg.eigvals(jacobian(x0, P))
    h = steady.stability(beta0, omega30, P)
    expected = np.sqrt(complex(h)) * np.array([1, -1])
    ev = ev[np.argsort(np.abs(ev))]
    scale = np.sqrt(abs(h))
    assert np.all(np.abs(ev[:2]) < 1e-5 * scale)  # the double zero eigenvalue (52)
    for lam in expected:  # lambda_{3,4}^2 = h (53)
        assert np.min(np.abs(ev[2:] - lam)) < 1e-5 * scale


@pytest.mark.parametrize("omega20_value", [0.0, 15.0, -40.0])
def test_trivial_motion_on_top_has_eigenvalue_sqrt_g_over_rho_over_1_plus_j(omega20_value):
    x0 = steady.trivial_state(+1, omega20_value, P)
    assert np.allclose(rolling.rolling_rhs(*x0, P.as_array()), 0, atol=1e-12)
    ev = np.linalg.eigvals(jacobian(x0, P))
    lam = steady.trivial_eigenvalue(P)
    assert np.max(ev.real) == pytest.approx(lam, rel=1e-6)
    assert lam == pytest.approx(np.sqrt(9.81 / 0.13 / (5 / 3)), rel=1e-12)


def test_hanging_trivial_motion_needs_negative_normal_force():
    x0 = steady.trivial_state(-1, np.array([0.0, 20.0]), P)
    F2 = vectorised(rolling.normal_force)(x0[..., 0], x0[..., 1], x0[..., 3], P.as_array())
    assert np.all(F2 < 0)


def test_beta_star_matches_paper():
    b = steady.beta_star(P)
    assert b == pytest.approx(0.273, abs=5e-4)
    assert np.degrees(b) == pytest.approx(15.6, abs=0.05)
    # for large omega30 the unstable band tends to |beta0| < beta*
    w = 1e4
    assert steady.stability(b - 0.01, w, P) > 0 and steady.stability(b + 0.01, w, P) < 0


def test_beta_hat_matches_paper_and_the_computed_map():
    b = steady.beta_hat(P)
    assert b == pytest.approx(0.144, abs=5e-4)
    assert np.degrees(b) == pytest.approx(8.3, abs=0.05)
    assert b < steady.beta_star(P)
    # cross-check: the smallest |beta0| at which some omega30 gives a stable motion (h < 0)
    beta = np.linspace(0.0, 0.3, 3001)
    omega = np.geomspace(1e-2, 1e3, 3001)
    stable_somewhere = (steady.stability(beta[:, None], omega[None, :], P) < 0).any(axis=1)
    assert beta[stable_somewhere].min() == pytest.approx(b, abs=2e-4)


def test_slip_condition_56_equals_the_rolling_forces():
    beta0 = np.linspace(-3.0, 3.0, 41)[:, None]
    omega30 = np.linspace(-60, 60, 40)[None, :]
    m, r, g, rho, R = P.m, P.r, P.g, P.rho, P.R
    D = R - rho * np.cos(beta0)
    normal = m * r**2 * omega30**2 * np.cos(beta0) / D + m * g * np.sin(beta0)
    tangential = np.abs(m * r**2 * omega30**2 * np.sin(beta0) / D - m * g * np.cos(beta0))
    for mu in (0.25, 1.0, 2.0):
        closed_form = mu * normal >= tangential
        ours = steady.rolls_without_slipping(beta0, omega30, P, mu)
        margin = np.abs(mu * normal - tangential) > 1e-9
        assert np.array_equal(closed_form[margin], ours[margin])
    assert np.array_equal(steady.stays_on_rim(beta0, omega30, P), normal >= 0)


def test_beta_tilde_is_45_degrees_at_mu_1():
    beta_tilde = np.arctan(1.0)
    assert np.degrees(beta_tilde) == pytest.approx(45.0)
    eps = np.radians(0.5)
    # small omega30: rolling realisable only for |beta0 - pi/2| < beta_tilde
    small = 1e-3
    assert steady.rolls_without_slipping(np.pi / 2 + beta_tilde - eps, small, P)
    assert steady.rolls_without_slipping(np.pi / 2 - beta_tilde + eps, small, P)
    assert not steady.rolls_without_slipping(np.pi / 2 + beta_tilde + eps, small, P)
    assert not steady.rolls_without_slipping(np.pi / 2 - beta_tilde - eps, small, P)
    # large omega30: |beta0| < beta_tilde
    large = 1e4
    assert steady.rolls_without_slipping(beta_tilde - eps, large, P)
    assert steady.rolls_without_slipping(-beta_tilde + eps, large, P)
    assert not steady.rolls_without_slipping(beta_tilde + eps, large, P)


def test_required_friction_level_set_is_the_slip_boundary():
    beta0 = np.linspace(-3.1, 3.1, 63)[:, None]
    omega30 = np.linspace(-60, 60, 61)[None, :]
    need = steady.required_friction(beta0, omega30, P)
    for mu in (0.5, 1.0, 2.0):
        away = np.abs(need - mu) > 1e-9
        assert np.array_equal((need <= mu)[away], steady.rolls_without_slipping(beta0, omega30, P, mu)[away])


def test_throw_speed_is_the_kinetic_energy_of_the_steady_motion():
    beta0, omega30 = 1.1, 12.0
    x = steady.steady_state(beta0, omega30, P)
    # T = 1/2 m |v_G|^2 + 1/2 j m r^2 |omega|^2 with v_G = -r omega3 n1 (13)
    T = 0.5 * P.m * (P.r * omega30) ** 2 + 0.5 * P.j * P.m * P.r**2 * (x[2] ** 2 + omega30**2)
    v = steady.throw_speed(beta0, omega30, P)
    assert 0.5 * P.m * v**2 == pytest.approx(T, rel=1e-12)


def test_minimal_throw_speeds_of_regions_match_fig8_text():
    """Region A exists from about 1 m/s, B from about 5, C from about 7 (Sect. 3.5)."""
    v_a = steady.minimal_throw_speed(steady.REGION_A, P)
    v_b = steady.minimal_throw_speed(steady.REGION_B, P)
    v_c = steady.minimal_throw_speed(steady.REGION_C, P)
    assert 0.5 < v_a < 1.5
    assert 4.5 < v_b < 5.5
    assert 6.5 < v_c < 7.5
    assert v_a < v_b < v_c


def test_region_labels_at_v_throw_10_and_3():
    beta0 = np.linspace(-np.pi, np.pi, 721, endpoint=False)[:, None]
    omega30 = np.linspace(-70, 70, 561)[None, :]
    at10 = steady.realisable_region(beta0, omega30, P, v_throw=10.0)
    present = set(np.unique(at10)) - {steady.REGION_NONE}
    assert present == {steady.REGION_A, steady.REGION_B, steady.REGION_C}
    area = {k: np.count_nonzero(at10 == k) for k in present}
    assert area[steady.REGION_A] > max(area[steady.REGION_B], area[steady.REGION_C])
    # both signs of omega20 occur in region A (Fig. 8's '+' and '-')
    w2 = np.broadcast_to(steady.omega20(beta0, omega30, P), at10.shape)[at10 == steady.REGION_A]
    assert (w2 > 0).any() and (w2 < 0).any()
    at3 = steady.realisable_region(beta0, omega30, P, v_throw=3.0)
    assert set(np.unique(at3)) == {steady.REGION_NONE, steady.REGION_A}


def test_region_letters_by_position():
    codes = steady.region_of(np.array([0.5, -0.5, 2.0, -2.0, 0.5 + 2 * np.pi]))
    assert codes.tolist() == [steady.REGION_A, steady.REGION_B, steady.REGION_C, steady.REGION_NONE, steady.REGION_A]


def test_singular_lines_give_nan_or_inf_not_errors():
    w2 = steady.omega20(np.array([np.pi / 2, 1.0]), np.array([5.0, 0.0]), P)
    assert np.all(~np.isfinite(w2) | (np.abs(w2) > 1e12))
