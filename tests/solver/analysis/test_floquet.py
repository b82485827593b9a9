"""Floquet analysis of (62)/(66): solver.floquet (paper Prop. 7, Fig. 9)."""

import numpy as np
import pytest
from scipy.integrate import solve_ivp

from rimroll import solver
from rimroll.solver.analysis import floquet
from rimroll.solver.physics.rolling import rolling_rhs
from tests.helpers.bounded_runs import P

X_STD = 0.13 / 0.225  # Table 1: rho/R
J_STD = 2.0 / 3.0


def _reference_monodromy(x, j, system="motion", rtol=1e-12):
    def f(b, y):
        return (floquet.system_matrix(b, x, j, system) @ y.reshape(2, 2)).ravel()

    sol = solve_ivp(f, (0.0, 2 * np.pi), np.eye(2).ravel(), method="DOP853", rtol=rtol, atol=1e-14)
    return sol.y[:, -1].reshape(2, 2)


def test_standard_ball_is_unstable():
    mu = floquet.multipliers(X_STD, J_STD)
    assert mu.shape == (2,)
    assert abs(mu[0]) < 1 < abs(mu[1])
    assert abs(mu[0] * mu[1] - 1) < 1e-10
    assert not floquet.is_stable(X_STD, J_STD)
    # the monodromy matrix's own eigenvalues agree with the trace-only multipliers
    ev = np.sort_complex(np.linalg.eigvals(floquet.monodromy(X_STD, J_STD)))
    assert np.allclose(np.sort_complex(mu), ev, rtol=1e-9)


@pytest.mark.parametrize("x,j", [(X_STD, J_STD), (0.05, 0.1), (0.3, 1.5), (0.7, 0.4), (0.95, 2 / 3)])
@pytest.mark.parametrize("system", ["motion", "coefficients"])
def test_det_monodromy_is_one(x, j, system):
    M = floquet.monodromy(x, j, system)
    assert abs(np.linalg.det(M) - 1) < 1e-10 * max(1.0, np.abs(M).max() ** 2)


@pytest.mark.parametrize("x,j", [(X_STD, J_STD), (0.2, 0.9), (0.9, 0.3)])
@pytest.mark.parametrize("system", ["motion", "coefficients"])
def test_monodromy_matches_scipy_dop853(x, j, system):
    M = floquet.monodromy(x, j, system)
    ref = _reference_monodromy(x, j, system)
    assert np.max(np.abs(M - ref)) < 1e-9 * np.abs(ref).max()
    assert abs(np.trace(M) - np.trace(ref)) < 1e-10 * max(1.0, abs(np.trace(ref)))


def test_coefficient_system_is_adjoint():
    """(66) is dc/dbeta = -A^T c, so its monodromy matrix is M^{-T}: same multipliers."""
    x = np.array([0.1, X_STD, 0.8])
    j = np.array([0.2, J_STD, 1.3])
    M = floquet.monodromy(x, j)
    Mc = floquet.monodromy(x, j, "coefficients")
    assert np.allclose(Mc, np.linalg.inv(M).transpose(0, 2, 1), rtol=1e-10, atol=1e-12)
    assert np.allclose(floquet.system_matrix(0.7, x, j, "coefficients"),
                       -floquet.system_matrix(0.7, x, j).transpose(0, 2, 1))


@pytest.mark.parametrize("scale", [1.0, 2.7])
def test_system_62_matches_rolling_equations(scale):
    """A(beta) of (62) is (omega2_dot, omega3_dot)/beta_dot of rolling_rhs, and depends on rho/R only."""
    p = solver.Params(r=0.12 * scale, R=0.225 * scale, a=0.01 * scale, mu=float("inf"))
    pa = p.as_array()
    for beta in (-2.5, -0.4, 0.0, 1.1, 3.0):
        A = np.empty((2, 2))
        for col, (w2, w3) in enumerate([(1.0, 0.0), (0.0, 1.0)]):
            bd, _, w2d, w3d = rolling_rhs(beta, 1.7, w2, w3, pa)
            A[:, col] = (w2d / bd, w3d / bd)
        assert np.allclose(A, floquet.system_matrix(beta, p.rho / p.R, p.j), rtol=1e-13, atol=1e-14)


def test_trace_of_A_integrates_to_zero():
    x, j = 0.8, 0.5
    beta = np.linspace(0, 2 * np.pi, 4001)
    tr = np.trace(floquet.system_matrix(beta, x, j), axis1=-2, axis2=-1)
    integral = np.sum((tr[1:] + tr[:-1]) / 2) * (beta[1] - beta[0])
    assert abs(integral) < 1e-10
    # Liouville: det Phi(beta) = (1 - x)/(1 - x cos beta)
    b = np.array([0.5, 2.0, -3.0, 7.0])
    phi = floquet.fundamental(b, x, j)
    assert np.allclose(np.linalg.det(phi), (1 - x) / (1 - x * np.cos(b)), rtol=1e-11)


def test_fundamental_matches_scipy_and_floquet_extension():
    x, j = X_STD, J_STD
    for b_end in (1.0, -2.2, 4.0, 9.5):
        def f(b, y):
            return (floquet.system_matrix(b, x, j) @ y.reshape(2, 2)).ravel()

        ref = solve_ivp(f, (0.0, b_end), np.eye(2).ravel(), method="DOP853", rtol=1e-12, atol=1e-14).y[:, -1]
        got = floquet.fundamental(b_end, x, j).ravel()
        assert np.max(np.abs(got - ref)) < 1e-9 * np.abs(ref).max()


def test_limit_small_rho_over_R_is_harmonic_oscillator():
    """rho/R -> 0: (62) -> omega2' = omega3, omega3' = -k omega2, multipliers exp(+-i 2 pi sqrt(k))."""
    j = np.array([0.1, 0.5, J_STD, 2.0])
    w = np.sqrt(j / (1 + j))
    mu = floquet.multipliers(1e-7, j)
    expected = np.exp(2j * np.pi * w)[:, None] * np.ones(2)
    expected[:, 0] = np.conj(expected[:, 0])  # the pair, ordered by Im (mu1 below the axis)
    order = np.argsort(mu.imag, axis=-1)
    expected = np.take_along_axis(expected, np.argsort(expected.imag, axis=-1), -1)
    assert np.allclose(np.take_along_axis(mu, order, -1), expected, atol=1e-6)
    assert np.allclose(floquet.trace(1e-7, j), 2 * np.cos(2 * np.pi * w), atol=1e-6)
    assert np.all(floquet.is_stable(1e-7, j))
    assert np.allclose(np.abs(mu), 1.0, atol=1e-15)


# Interior points of a computed 20 x 20 map (x in [0.025, 0.975], j in [0.05, 1]); |tr M| margin
# checked below. S: small rho/R or small j (Prop. 7, Fig. 9); U: the standard ball's side, and
# the parametric-resonance tongue from (x, j) = (0, 1/3) where 2 sqrt(j/(1+j)) = 1.
STABLE = [(0.05, 0.05), (0.3, 0.05), (0.6, 0.05), (0.05, 0.8), (0.2, 0.9), (0.1, 0.15)]
UNSTABLE = [(X_STD, J_STD), (0.8, 0.5), (0.9, 0.1), (0.5, 0.4), (0.15, 1 / 3)]


def test_regions_classified():
    xs, js = np.array(STABLE + UNSTABLE).T
    tr = floquet.trace(xs, js)
    stable = floquet.is_stable(xs, js)
    n = len(STABLE)
    assert stable[:n].all() and not stable[n:].any()
    assert np.all(np.abs(np.abs(tr) - 2) > 0.05)  # well inside each region
    mu = floquet.multipliers(xs, js)
    assert np.allclose(np.abs(mu[:n]), 1.0, atol=1e-14)
    assert np.all(np.abs(mu[n:, 0]) < 1) and np.all(np.abs(mu[n:, 1]) > 1)


def test_broadcasting():
    x = np.array([0.1, 0.5, 0.9])[:, None]
    j = np.array([0.2, 0.6, 1.0, 3.0])
    mu = floquet.multipliers(x, j)
    M = floquet.monodromy(x, j)
    assert mu.shape == (3, 4, 2) and M.shape == (3, 4, 2, 2)
    assert floquet.is_stable(x, j).shape == (3, 4)
    for a in range(3):
        for b in range(4):
            assert np.allclose(mu[a, b], floquet.multipliers(x[a, 0], j[b]), rtol=1e-12)


def test_multipliers_from_trace_no_cancellation():
    mu = floquet.multipliers_from_trace(np.array([1e8, -1e8, 2.0, 0.0]))
    assert mu[0, 0].real == pytest.approx(1e-8, rel=1e-15)
    assert mu[1, 0].real == pytest.approx(-1e-8, rel=1e-15)
    assert np.allclose(mu[2], [1, 1]) and np.allclose(mu[3], [-1j, 1j])


@pytest.mark.parametrize("x,j,name", [(0.0, 0.5, "rho_over_R"), (1.0, 0.5, "rho_over_R"),
                                      (0.5, 0.0, "j"), (0.5, np.inf, "j"), (np.nan, 0.5, "rho_over_R")])
def test_invalid_inputs(x, j, name):
    with pytest.raises(ValueError, match=name):
        floquet.multipliers(x, j)
    with pytest.raises(ValueError, match=name):
        floquet.monodromy(np.array([0.3, x]), j)


def test_monodromy_of_the_most_unstable_ball_on_the_fig9_range():
    """max |tr M| over Fig. 9's default 200 x 200 grid; there det M = 1 and mu1 mu2 = 1."""
    n = 200
    x_max = 1.0 - P.a / P.R
    x = (np.arange(n) + 0.5) / n * x_max
    j = (np.arange(n) + 1.0) / n * (2.0 / 3.0)
    X, J = np.meshgrid(x, j, indexing="ij")
    tr = floquet.trace(X, J)
    assert np.all(np.isfinite(tr))
    k = np.unravel_index(np.argmax(np.abs(tr)), tr.shape)
    xs, js = float(X[k]), float(J[k])
    M = floquet.monodromy(xs, js)
    assert abs(np.trace(M) - tr[k]) <= 1e-9 * abs(tr[k])
    assert abs(np.linalg.det(M) - 1.0) <= 1e-9 * np.abs(M).max() ** 2
    mu = floquet.multipliers(xs, js)
    assert abs(mu[0] * mu[1] - 1.0) < 1e-9
    assert abs(mu[1]) > 1.0 > abs(mu[0])  # unstable (region U)
    eig = np.sort(np.abs(np.linalg.eigvals(M)))
    assert eig[1] == pytest.approx(abs(mu[1]), rel=1e-9)
