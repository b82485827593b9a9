"""Every type of Theorem 1 / Table 2 on constructed states: connections of the trivial and of
non-trivial saddles (types 3, 4), rotations with rational (type 6) and irrational (type 7)
rotation number, and the reduced (beta, omega1) dynamics the classifier stands on."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.integrate import solve_ivp
from scipy.optimize import brentq, newton

from rimroll import solver
from rimroll.solver.analysis import floquet, reduced, steady, trajectory
from rimroll.solver.analysis import solution_types as st
from rimroll.solver.physics import rolling
from rimroll.solver.physics.kinematics import alpha_rate

P_ROLL = solver.Params(mu=float("inf"))
SADDLES = [(1.0, 5.0), (0.0, 10.0), (-0.5, 10.0), (-1.5, 5.0)]  # (beta0, omega30) with h > 0 in (54)
GOLDEN = (3.0 - np.sqrt(5.0)) / 2.0  # an irrational rotation number in (0, 1/2)
STABLE_X = 0.5  # rho/R of a ball of the stable region of Fig. 9 (with small j)


def _jacobian(x, p, h=1e-7):
    pa = p.as_array()
    J = np.empty((4, 4))
    for k in range(4):
        e = np.zeros(4)
        e[k] = h
        J[:, k] = (np.array(rolling.rolling_rhs(*(x + e), pa)) - np.array(rolling.rolling_rhs(*(x - e), pa))) / (2 * h)
    return J


def _newton_saddle(beta0, omega30, p):
    """The steady motion at (beta0, omega30) by Newton's method on omega1_dot(beta0, 0, omega2, omega30) = 0
    from a guess 10 % off, independently of (48)."""
    pa = p.as_array()
    guess = 1.1 * steady.omega20(beta0, omega30, p)
    w2 = newton(lambda w: rolling.rolling_rhs(beta0, 0.0, w, omega30, pa)[1], guess, tol=1e-13, maxiter=100)
    return np.array([beta0, 0.0, w2, omega30])


def _on_stable_manifold(x_eq, p, side, eps=1e-7, distance=0.05):
    """A state on the stable manifold of x_eq: x_eq + eps v_s (v_s the stable eigenvector of the
    linearisation) followed backward in time, where the stable manifold attracts, until its
    scaled distance from x_eq (that of the classifier) first exceeds ``distance``."""
    w, V = np.linalg.eig(_jacobian(x_eq, p))
    v = V[:, int(np.argmin(w.real))].real
    start = x_eq + side * eps * v / np.linalg.norm(v)
    t = -np.linspace(0.0, 40.0 / float(np.max(w.real)), 4001)
    path = trajectory.rolling_trajectory(start, p, t, rtol=1e-12, atol=1e-14)
    k = int(np.argmax(st._scaled_distance(path, x_eq, p) > distance))
    assert k > 0, "the backward solution never got that far"
    return path[k]


def _stable_params(rotation_number):
    """Params of the stable region of Fig. 9 (rho/R = 0.5) whose Floquet rotation number of (62) is given."""
    target = 2.0 * np.cos(2.0 * np.pi * rotation_number)
    j = brentq(lambda j: floquet.trace(STABLE_X, j) - target, 0.005, 0.1, xtol=1e-15)
    return solver.Params.from_rho_over_R(STABLE_X, j=j, mu=float("inf"))


# ----------------------------------------------------------------------------- codes
def test_codes_are_the_items_of_theorem_1():
    names = st.TYPE_FLAG_MEANINGS.split()
    assert names == ["undetermined", "trivial_equilibrium", "nontrivial_equilibrium", "trivial_connection",
                     "nontrivial_connection", "non_periodic_pendulum", "periodic", "quasi_periodic"]
    assert st.TYPE_FLAG_VALUES == tuple(range(8))
    assert (st.TRIVIAL_CONNECTION, st.NONTRIVIAL_CONNECTION, st.QUASI_PERIODIC) == (3, 4, 7)
    assert st.CONNECTION_FLAG_MEANINGS.split() == ["not_a_connection", "homoclinic", "heteroclinic",
                                                   "other_end_unresolved"]


# ----------------------------------------------------------------------------- reduced dynamics
@pytest.mark.parametrize("beta0, omega30", [*SADDLES, (0.6, 10.0), (2.0, -8.0)])
def test_reduced_equilibrium_by_newton_is_the_steady_motion_and_its_eigenvalue_is_h(beta0, omega30):
    x0 = steady.steady_state(beta0, omega30, P_ROLL)
    found = reduced.equilibrium(reduced.level(x0, P_ROLL), beta0 + 0.01, P_ROLL)
    np.testing.assert_allclose(found, x0, rtol=0, atol=1e-10 * (1 + np.abs(x0).max()))
    h = steady.stability(beta0, omega30, P_ROLL)
    assert reduced.eigenvalue_squared(found, P_ROLL) == pytest.approx(h, rel=1e-6)
    assert np.isnan(reduced.saddle_rate(found, P_ROLL)) == (h < 0)


def test_reduced_rate_is_minus_the_slope_of_the_potential():
    x0 = np.array([0.7, 3.0, -20.0, 12.0])
    P = reduced.level(x0, P_ROLL)
    beta = np.linspace(-1.0, 2.0, 7)
    h = 1e-6
    dU = (reduced.potential(beta + h, P, P_ROLL) - reduced.potential(beta - h, P, P_ROLL)) / (2 * h)
    G = reduced.omega1_rate(beta, P, P_ROLL)
    np.testing.assert_allclose(G, -(P_ROLL.r / P_ROLL.rho) * dU / (P_ROLL.m * (1 + P_ROLL.j) * P_ROLL.r**2),
                               rtol=1e-7, atol=1e-9)
    # z(beta) = Phi(beta) P follows the solution: compare with the integrated state at its beta
    x = trajectory.rolling_trajectory(x0, P_ROLL, [0.05], rtol=1e-12, atol=1e-14)[0]
    np.testing.assert_allclose(reduced.spins(x[0], P, P_ROLL), x[2:], rtol=1e-9)


# ----------------------------------------------------------------------------- types 3 and 4
@pytest.mark.parametrize("side", [1, -1])
@pytest.mark.parametrize("beta0, omega30", SADDLES)
def test_state_on_the_stable_manifold_of_a_nontrivial_saddle_is_type_4(beta0, omega30, side):
    x_eq = _newton_saddle(beta0, omega30, P_ROLL)
    np.testing.assert_allclose(x_eq, steady.steady_state(beta0, omega30, P_ROLL), rtol=1e-12)  # (48)
    h = steady.stability(beta0, omega30, P_ROLL)
    assert h > 0
    x0 = _on_stable_manifold(x_eq, P_ROLL, side)
    res = st.classify(x0, P_ROLL)
    assert res["type"] == st.NONTRIVIAL_CONNECTION
    assert res["beta_eq"] == pytest.approx(beta0, abs=1e-8)
    assert res["omega3_eq"] == pytest.approx(omega30, rel=1e-8)
    assert res["saddle_rate"] == pytest.approx(np.sqrt(h), rel=1e-12)
    assert res["approach_rate"] == pytest.approx(np.sqrt(h), rel=st.RATE_TOL)
    assert res["connection"] == st.HOMOCLINIC  # the paper: "it seems that all connections are homoclinic"
    assert np.isnan(res["half_period"]) and np.isnan(res["period"])


@pytest.mark.parametrize("omega2", [0.0, 20.0, -35.0])
def test_state_on_the_stable_manifold_of_the_ball_on_top_is_type_3(omega2):
    x_eq = steady.trivial_state(1, omega2, P_ROLL)
    x0 = _on_stable_manifold(x_eq, P_ROLL, 1)
    assert abs(x0[3]) > 0.01 or omega2 == 0.0  # omega3 != 0 off the pendulum plane
    res = st.classify(x0, P_ROLL)
    assert res["type"] == st.TRIVIAL_CONNECTION
    assert res["beta_eq"] == pytest.approx(np.pi / 2, abs=1e-8)
    assert res["omega2_eq"] == pytest.approx(omega2, abs=1e-7)
    lam = steady.trivial_eigenvalue(P_ROLL)
    assert res["saddle_rate"] == pytest.approx(lam, rel=1e-12)
    assert res["approach_rate"] == pytest.approx(lam, rel=st.RATE_TOL)


@pytest.mark.parametrize("sign", [1.0, -1.0])
def test_pendulum_separatrix_is_a_homoclinic_connection_of_the_top(sign):
    """E = m g rho in the plane omega2 = omega3 = 0 (Prop. 6): rising to the top, it tends to
    x0+; falling, to beta = pi/2 - 2 pi, the same equilibrium of the phase space (beta an angle)."""
    p = P_ROLL
    w1 = sign * np.sqrt(2 * (1.0 - np.sin(0.4)) * p.m * p.g * p.rho / (p.m * (1 + p.j) * p.r**2))
    res = st.classify(np.array([0.4, w1, 0.0, 0.0]), p)
    assert res["type"] == st.TRIVIAL_CONNECTION and res["connection"] == st.HOMOCLINIC
    assert res["beta_eq"] == pytest.approx(np.pi / 2, abs=1e-8)
    assert res["approach_rate"] == pytest.approx(steady.trivial_eigenvalue(p), rel=st.RATE_TOL)


@pytest.mark.parametrize("offset", [0.05, -0.08])
def test_reduced_stable_manifold_state_is_a_connection(offset):
    x_eq = steady.steady_state(0.0, 10.0, P_ROLL)
    x0 = reduced.stable_manifold_state(x_eq, offset, P_ROLL)
    assert solver.invariants(x0, P_ROLL)["E"] == pytest.approx(float(solver.invariants(x_eq, P_ROLL)["E"]),
                                                               rel=1e-13)
    res = st.classify(x0, P_ROLL)
    assert res["type"] == st.NONTRIVIAL_CONNECTION and res["beta_eq"] == pytest.approx(0.0, abs=1e-8)
    with pytest.raises(ValueError, match="not a saddle"):
        reduced.stable_manifold_state(steady.steady_state(0.6, 10.0, P_ROLL), 0.05, P_ROLL)


def test_a_periodic_orbit_near_a_separatrix_is_not_a_connection():
    """Off the stable manifold by 1e-4 of the energy scale: it turns back, and is periodic."""
    x_eq = steady.steady_state(1.0, 5.0, P_ROLL)
    x0 = reduced.stable_manifold_state(x_eq, 0.1, P_ROLL)
    x0[1] *= 1.0 - 1e-4
    res = st.classify(x0, P_ROLL)
    assert res["type"] == st.PERIODIC and res["connection"] == st.NOT_A_CONNECTION


# ----------------------------------------------------------------------------- types 6 and 7 (rotations)
@pytest.mark.parametrize("nu, q", [(0.25, 4), (1.0 / 3.0, 3)])
def test_rotation_with_rational_rotation_number_is_periodic(nu, q):
    p = _stable_params(nu)
    x0 = np.array([0.3, 25.0, 3.0, -2.0])
    res = st.classify(x0, p)
    assert res["type"] == st.PERIODIC
    assert np.isnan(res["half_period"])  # no zero of omega1: not Prop. 4
    assert res["rotation_number"] == pytest.approx(nu, abs=1e-9)
    assert res["revolutions"] >= st.MIN_REVOLUTIONS
    # after one period the state is back, beta advanced by q turns
    back = trajectory.rolling_trajectory(x0, p, [res["period"]], rtol=1e-12, atol=1e-14)[0]
    np.testing.assert_allclose(back - [2 * np.pi * q, 0, 0, 0], x0, rtol=0, atol=1e-7 * np.abs(x0).max())
    half = trajectory.rolling_trajectory(x0, p, [res["period"] / 2], rtol=1e-12, atol=1e-14)[0]
    assert np.abs(half[2:] - x0[2:]).max() > 0.1  # and not before


def test_rotation_with_irrational_rotation_number_is_quasi_periodic():
    p = _stable_params(GOLDEN)
    assert floquet.is_stable(p.rho / p.R, p.j)  # Prop. 7: only in the stable region of Fig. 9
    x0 = np.array([0.3, 25.0, 3.0, -2.0])
    res = st.classify(x0, p)
    assert res["type"] == st.QUASI_PERIODIC
    assert res["rotation_number"] == pytest.approx(GOLDEN, abs=1e-9)  # against the Floquet trace of (62)
    assert np.isnan(res["period"]) and np.isnan(res["alpha_advance"])
    # (omega2, omega3) at the returns of beta fill an ellipse: no return to z0 among those seen
    found = trajectory.scan(x0, p, st.DEFAULT_T_MAX, n_zeros=None)
    z = found.return_states[:, 2:]
    assert z.shape[0] == res["revolutions"]
    assert np.abs(z - x0[2:]).max(axis=1).min() > 1e-3 * np.abs(x0[2:]).max()


def test_standard_ball_rotation_grows_and_is_not_quasi_periodic():
    """Region U of Fig. 9 (Prop. 8): (omega2, omega3) grow from revolution to revolution."""
    res = st.classify(np.array([0.3, 25.0, 0.3, -0.2]), P_ROLL, t_max=3.0)
    assert res["type"] != st.QUASI_PERIODIC and np.isnan(res["rotation_number"])


# ----------------------------------------------------------------------------- alpha is not in the phase space
def test_alpha_advance_of_a_periodic_orbit_against_direct_integration():
    """alpha_advance is the integral of (19) over one period; whatever its ratio to 2 pi, the
    orbit in the phase space (beta, omega) of the paper is periodic (type 6)."""
    x0 = np.array([0.3, 5.0, 20.0, 10.0])
    res = st.classify(x0, P_ROLL)
    assert res["type"] == st.PERIODIC
    pa = P_ROLL.as_array()

    def rhs(t, y):
        return [*rolling.rolling_rhs(y[0], y[1], y[2], y[3], pa), alpha_rate(y[0], y[3], 0.0, pa)]

    sol = solve_ivp(rhs, (0, float(res["period"])), [*x0, 0.0], method="DOP853", rtol=1e-12, atol=1e-14)
    assert res["alpha_advance"] == pytest.approx(sol.y[4, -1], rel=1e-8)
    assert abs(res["alpha_advance"]) > 0.1


# ----------------------------------------------------------------------------- what docs/solution-types.md says
def test_connections_subset_gives_connections_all_homoclinic():
    from rimroll.workflows.solution_type_samples import sample_states

    s = {"n_samples": 10, "seed": 0, "subset": "connections", "omega1_max": 20.0, "omega2_max": 70.0,
         "omega3_max": 70.0}
    res = st.classify(sample_states(s, P_ROLL), P_ROLL)
    np.testing.assert_array_equal(res["type"], [st.NONTRIVIAL_CONNECTION] * 4 + [st.TRIVIAL_CONNECTION]
                                  + [st.NONTRIVIAL_CONNECTION] * 4 + [st.TRIVIAL_CONNECTION])
    assert np.all(res["connection"] == st.HOMOCLINIC)


def test_docs_example_ball_is_stable_with_rotation_number_0_3818():
    p = solver.Params(r=0.1025, j=0.08)
    assert p.rho / p.R == pytest.approx(0.5)
    nu = np.arccos(floquet.trace(p.rho / p.R, p.j) / 2) / (2 * np.pi)
    assert round(float(nu), 4) == 0.3818
    res = st.classify(np.array([0.3, 30.0, 2.0, -1.0]), p.replace(mu=float("inf")), t_max=10.0)
    assert res["type"] == st.QUASI_PERIODIC and res["rotation_number"] == pytest.approx(nu, abs=1e-8)
