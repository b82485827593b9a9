"""Conserved quantities E (60), P_I, P_II (65)-(68) and the limit forms (69), (72)."""

import numpy as np
import pytest
from scipy.integrate import solve_ivp

from rimroll import solver
from rimroll.solver.analysis import floquet
from rimroll.solver.analysis.invariants import momenta, prop11_invariants, prop12_invariants
from rimroll.solver.physics.rolling import rolling_rhs

P_STD = solver.Params(mu=float("inf"))


def _trajectory(y0, t_end, p, omega2_factor=1.0):
    pa = p.as_array()

    def f(t, y):
        bd, w1d, w2d, w3d = rolling_rhs(y[0], y[1], y[2], y[3], pa)
        return [bd, w1d, omega2_factor * w2d, w3d]

    sol = solve_ivp(f, (0.0, t_end), y0, method="DOP853", rtol=1e-11, atol=1e-12,
                    t_eval=np.linspace(0.0, t_end, 301))
    assert sol.success
    return sol.y.T


def _scale(states, p):
    """Size of the terms summed in P = [omega2, omega3] Psi c, to measure changes against."""
    psi = floquet.fundamental(states[:, 0], p.rho / p.R, p.j, "coefficients")
    w = np.abs(states[:, 2:4])
    return np.max(w[:, :1] * np.abs(psi[:, 0, :]) + w[:, 1:] * np.abs(psi[:, 1, :]), axis=0)


def _max_relative_change(states, p):
    inv = solver.invariants(states, p)
    s_one, s_two = _scale(states, p)
    return {
        "E": np.ptp(inv["E"]) / np.abs(inv["E"]).max(),
        "P_I": np.ptp(inv["P_I"]) / s_one,
        "P_II": np.ptp(inv["P_II"]) / s_two,
    }


STEADY_NEAR = [1.2, 2.0, float(solver.steady.omega20(1.2, 10.0, P_STD)), 10.0]
AROUND = [0.0, 40.0, 3.0, 2.0]  # omega1 large: beta goes around the rim twice (Floquet extension)


@pytest.mark.parametrize("y0,t_end", [(STEADY_NEAR, 4.0), (AROUND, 0.5)])
def test_conserved_along_rolling_trajectory(y0, t_end):
    states = _trajectory(y0, t_end, P_STD)
    if y0 is AROUND:
        assert states[:, 0].max() > 3 * np.pi  # beyond a full turn: Psi(beta + 2 pi) = Psi M^{-T} used
    change = _max_relative_change(states, P_STD)
    assert change["E"] < 1e-9
    assert change["P_I"] < 1e-9
    assert change["P_II"] < 1e-9


@pytest.mark.parametrize("y0,t_end", [(STEADY_NEAR, 4.0), (AROUND, 0.5)])
def test_not_conserved_along_wrong_vector_field(y0, t_end):
    states = _trajectory(y0, t_end, P_STD, omega2_factor=1.05)
    change = _max_relative_change(states, P_STD)
    assert change["P_I"] > 1e-3 and change["P_II"] > 1e-3


def test_dP_dt_vanishes_at_random_states():
    """Chain rule: dP/dt = dP/dbeta beta_dot + Psi-row . (omega2_dot, omega3_dot), dP/dbeta by differences."""
    rng = np.random.default_rng(4)
    for p in (P_STD, solver.Params.from_rho_over_R(0.3, j=0.4, mu=float("inf"))):
        pa = p.as_array()
        x = p.rho / p.R
        states = np.column_stack([rng.uniform(-7, 7, 40), rng.uniform(-20, 20, 40),
                                  rng.uniform(-30, 30, 40), rng.uniform(-30, 30, 40)])
        h = 1e-5
        for factor, expect_zero in ((1.0, True), (1.05, False)):
            bd, _, w2d, w3d = (np.array(v) for v in zip(*(rolling_rhs(*s, pa) for s in states)))
            w2d = factor * w2d
            b, w2, w3 = states[:, 0], states[:, 2], states[:, 3]
            psi = floquet.fundamental(b, x, p.j, "coefficients")
            plus = np.array(momenta(b + h, w2, w3, x, p.j))
            minus = np.array(momenta(b - h, w2, w3, x, p.j))
            dP_dbeta = (plus - minus) / (2 * h)
            dP_dt = dP_dbeta * bd + psi[:, 0, :].T * w2d + psi[:, 1, :].T * w3d
            size = np.abs(dP_dbeta * bd) + np.abs(psi[:, 0, :].T * w2d) + np.abs(psi[:, 1, :].T * w3d)
            rel = np.abs(dP_dt) / size
            if expect_zero:
                assert rel.max() < 1e-7
            else:
                assert np.median(rel) > 1e-3


def test_values_at_beta_zero_and_shapes():
    rng = np.random.default_rng(0)
    states = rng.normal(size=(3, 5, 4)) * 5
    states[..., 0] = 0.0
    inv = solver.invariants(states, P_STD)
    assert set(inv) == {"E", "P_I", "P_II"}
    assert all(v.shape == (3, 5) for v in inv.values())
    assert np.allclose(inv["P_I"], states[..., 2], rtol=1e-14) and np.allclose(inv["P_II"], states[..., 3], rtol=1e-14)
    with pytest.raises(ValueError, match="states"):
        solver.invariants(np.zeros((3, 3)), P_STD)


def _fit_and_check(general, closed, n_fit=4):
    """Fit closed = T @ general (2x2 T) on the first n_fit states, return T and the max residual on the rest."""
    G = np.asarray(general).T  # (N, 2)
    C = np.asarray(closed).T
    T, *_ = np.linalg.lstsq(G[:n_fit], C[:n_fit], rcond=None)
    resid = np.abs(G[n_fit:] @ T - C[n_fit:]).max() / np.abs(C[n_fit:]).max()
    return T.T, resid


def _limit_states(rng, n, beta_max):
    return rng.uniform(-beta_max, beta_max, n), rng.uniform(-20, 20, n), rng.uniform(-20, 20, n)


def test_prop11_limit_R_to_infinity():
    j = 2 / 3
    w = np.sqrt(j / (1 + j))
    beta, w2, w3 = _limit_states(np.random.default_rng(1), 30, 6.0)
    closed = prop11_invariants(beta, w2, w3, j)
    residuals = []
    for x in (1e-2, 1e-3, 1e-4):
        T, resid = _fit_and_check(momenta(beta, w2, w3, x, j), closed)
        residuals.append(resid)
    assert residuals[2] < 1e-3 and residuals[0] > 3 * residuals[1] > 9 * residuals[2]  # ~ O(rho/R)
    # c(0) = (1, 0) -> P = -P_II^(69)/w;  c(0) = (0, 1) -> P = P_I^(69)
    assert np.allclose(T, [[0, 1], [-w, 0]], atol=1e-3)
    # through the public API with a huge rim
    p = solver.Params(R=1e4, mu=float("inf"))
    inv = solver.invariants(np.column_stack([beta, 0 * beta, w2, w3]), p)
    tol = 1e-3 * np.abs(closed).max()
    assert np.allclose(inv["P_II"], closed[0], atol=tol) and np.allclose(-w * inv["P_I"], closed[1], atol=tol)


def _coefficients_R_over_rho(beta_end, x, j):
    """Psi(beta_end) of (66) with coefficients written through R/rho (valid for rho/R > 1, inf)."""
    def f(b, y):
        return (floquet.system_matrix(b, x, j, "coefficients") @ y.reshape(2, 2)).ravel()

    if beta_end == 0:
        return np.eye(2)
    sol = solve_ivp(f, (0.0, beta_end), np.eye(2).ravel(), method="DOP853", rtol=1e-12, atol=1e-14)
    return sol.y[:, -1].reshape(2, 2)


def test_prop12_limit_R_to_zero():
    """R -> 0 at fixed rho: R/(R - rho cos) -> 0, rho sin/(R - rho cos) -> -tan beta in (66)."""
    j = 2 / 3
    beta, w2, w3 = _limit_states(np.random.default_rng(2), 12, 1.2)  # away from cos beta = R/rho
    closed = prop12_invariants(beta, w2, w3, j)

    def general(x):
        psi = np.array([_coefficients_R_over_rho(b, x, j) for b in beta])
        return w2 * psi[:, 0, 0] + w3 * psi[:, 1, 0], w2 * psi[:, 0, 1] + w3 * psi[:, 1, 1]

    residuals = [_fit_and_check(general(x), closed)[1] for x in (1e2, 1e3, 1e4)]
    assert residuals[2] < 1e-3 and residuals[0] > 3 * residuals[1] > 9 * residuals[2]  # ~ O(R/rho)
    T, resid = _fit_and_check(general(np.inf), closed)
    assert resid < 1e-10
    assert np.allclose(T, [[1, 0], [0, 1 + j]], atol=1e-9)  # c(0) = (1, 0) -> omega2; (0, 1) -> P_II/(1+j)


def test_prop12_and_prop11_closed_forms_conserved_in_their_limits():
    """The closed forms satisfy P = c . z with c solving (66) at rho/R = inf / 0 (direct check of (69), (72))."""
    rng = np.random.default_rng(3)
    j = 0.45
    for closed, x in ((prop12_invariants, np.inf), (prop11_invariants, 0.0)):
        for beta in rng.uniform(-1.2, 1.2, 5):
            h = 1e-6
            # c = gradient of P in (omega2, omega3); check dc/dbeta = -A^T c
            def coeffs(b):  # rows: (c2, c3) of P_I and of P_II; called in this iteration only
                rows = [[closed(b, 1.0, 0.0, j)[i], closed(b, 0.0, 1.0, j)[i]] for i in range(2)]  # noqa: B023
                return np.array(rows)

            dc = (coeffs(beta + h) - coeffs(beta - h)) / (2 * h)
            A = floquet.system_matrix(beta, x if x > 0 else 1e-300, j, "coefficients")
            assert np.allclose(dc, coeffs(beta) @ A.T, atol=1e-8)
