"""The terms of Sect. 5.3's open question: Coulomb rolling and drilling resistance, air drag.

Per term: the rolling rates against a Newton-Euler derivation of our own in the lab frame (not the
n-basis algebra of ``solver.physics.loads``); the energy balance dE/dt = the term's power, pointwise
(both phases) and along trajectories; zero strength gives the scene without the term bit for bit;
the engine against the scipy reference; the flight with drag against scipy and the parabola.
"""

from __future__ import annotations

import numpy as np
import pytest
from scipy.integrate import solve_ivp

from rimroll import solver
from rimroll.solver.analysis.scipy_reference import reference
from rimroll.solver.engine import outcomes, scenes
from rimroll.solver.physics import air, flight, kinematics, loads, resistance, rolling, slipping
from tests.helpers.finite_differences import gradient

RNG = np.random.default_rng(20261125)
TERMS = {  # term name: (its load function, Params that switch it on at a strength of note)
    "coulomb_rolling": (resistance.coulomb_rolling, {"c_r": 2e-3}),
    "coulomb_drilling": (resistance.coulomb_drilling, {"c_d": 3e-3}),
    "air_drag": (air.air_drag, {"rho_air": 1.2}),
}
NEW_TERMS = tuple(TERMS)


def rolling_states(n):
    """Rolling states on the rim with F2 > 0 (the ball pressed onto the rim)."""
    pa = solver.Params().as_array()
    out = []
    while len(out) < n:
        x = np.array([RNG.uniform(0.6, 1.8), RNG.uniform(-8, 8), RNG.uniform(-80, 80), RNG.uniform(-20, 20)])
        if rolling.normal_force(x[0], x[1], x[3], pa) > 0.5:
            out.append(x)
    return np.array(out)


def lab_rolling_rates(x, p: solver.Params, load):
    """The rolling rates (omega1_dot, omega2_dot, omega3_dot) [1/s^2] from the Newton-Euler equations
    written in the lab frame (at alpha = 0) with a load (M [N m] about the centre, F [N] at it, in the
    n-basis), solved as one linear system for the centre's acceleration, the ball's angular
    acceleration and the contact force, with the rolling constraint differentiated once."""
    beta, w1, w2, w3 = x
    m, r, rho, R, j, g = p.m, p.r, p.rho, p.R, p.j, p.g
    e_r, e_a, e_z = np.eye(3)
    n1 = e_a
    n2 = -np.cos(beta) * e_r + np.sin(beta) * e_z
    n3 = np.sin(beta) * e_r + np.cos(beta) * e_z
    omega = w1 * n1 + w2 * n2 + w3 * n3
    alpha_dot = -r * w3 / (R - rho * np.cos(beta))  # rolling: V1 = -r omega3, V3 = r omega1 (19), (20)
    beta_dot = r * w1 / rho
    Omega = alpha_dot * e_z + beta_dot * n1  # angular velocity of the basis (n1, n2, n3)
    M = load[0] * n1 + load[1] * n2 + load[2] * n3
    F = load[3] * n1 + load[4] * n2 + load[5] * n3
    J = j * m * r * r
    # unknowns z = (a_C, omega_dot, F_contact); rows: Newton, Euler about the centre, d/dt of v_P = 0
    A = np.zeros((9, 9))
    b = np.zeros(9)
    A[0:3, 0:3] = m * np.eye(3)
    A[0:3, 6:9] = -np.eye(3)
    b[0:3] = F - m * g * e_z
    lever = -r * n2  # contact point from the centre

    def cross_matrix(v):
        return np.array([[0, -v[2], v[1]], [v[2], 0, -v[0]], [-v[1], v[0], 0]])

    A[3:6, 3:6] = J * np.eye(3)
    A[3:6, 6:9] = -cross_matrix(lever)
    b[3:6] = M
    # v_P = v_C + omega x lever = 0  =>  a_C + omega_dot x lever + omega x lever_dot = 0
    A[6:9, 0:3] = np.eye(3)
    A[6:9, 3:6] = -cross_matrix(lever)  # omega_dot x lever = -lever x omega_dot
    b[6:9] = -np.cross(omega, -r * np.cross(Omega, n2))
    z = np.linalg.solve(A, b)
    omega_dot = z[3:6]
    return np.array([omega_dot @ n + omega @ np.cross(Omega, n) for n in (n1, n2, n3)])


@pytest.mark.parametrize("name", ("none", *NEW_TERMS))
def test_rolling_rates_with_the_term_equal_a_lab_frame_newton_euler_derivation(name):
    load_fn, on = TERMS.get(name, (None, {}))
    p = solver.Params(**on)
    pa = p.as_array()
    for x in rolling_states(25):
        load = load_fn(*x, 0.0, 0.0, pa) if load_fn else (0.0,) * 6
        ours = np.array(rolling.rolling_rhs(*x, pa, load if load_fn else None)[1:])
        lab = lab_rolling_rates(x, p, load)
        np.testing.assert_allclose(ours, lab, rtol=1e-10, atol=1e-10 * np.abs(lab).max())
        if load_fn:  # the term changes the rates, so the comparison checks it
            assert np.abs(ours - np.array(rolling.rolling_rhs(*x, pa)[1:])).max() > 1e-6


R_BALL = solver.Params().r


def _centre_velocity(x, u1=0.0, u3=0.0, r=R_BALL):
    return u1 - r * x[3], 0.0, u3 + r * x[1]


@pytest.mark.parametrize("name", NEW_TERMS)
def test_energy_rate_is_the_power_of_the_term_pointwise_in_both_phases(name):
    load_fn, on = TERMS[name]
    pa = solver.Params(**on).as_array()
    for x in rolling_states(15):
        load = load_fn(*x, 0.0, 0.0, pa)
        rates = np.array(rolling.rolling_rhs(*x, pa, load))
        grad = gradient(lambda z: rolling.energy(*z, pa), x)
        power = loads.power(load, x[1], x[2], x[3], *_centre_velocity(x))
        assert power < 0
        assert grad @ rates == pytest.approx(power, abs=1e-6 * np.abs(grad * rates).max())
    for x in rolling_states(15):  # slipping: dE/dt = friction power + the term's power
        y = np.array([*x, RNG.uniform(-0.3, 0.3), RNG.uniform(-0.3, 0.3)])
        load = load_fn(*y, pa)
        rates = np.array(slipping.slipping_rhs(*y, pa, load))
        grad = gradient(lambda z: slipping.energy(*z, pa), y)
        F2 = slipping.slipping_normal_force(y[0], y[1], y[3], y[4], y[5], pa, load)
        friction = -pa[5] * F2 * np.hypot(y[4], y[5])  # -mu F2 |u|: Coulomb friction's power (29)
        power = loads.power(load, y[1], y[2], y[3], *_centre_velocity(x, y[4], y[5]))
        assert grad @ rates == pytest.approx(friction + power, abs=1e-6 * np.abs(grad * rates).max())


@pytest.mark.parametrize("name", NEW_TERMS)
def test_energy_lost_along_a_trajectory_is_the_work_of_the_term(name):
    """E(t) - E(0) = the integral of the term's power, along a rolling trajectory (scipy, rtol 1e-12)."""
    load_fn, on = TERMS[name]
    pa = solver.Params(mu=np.inf, **on).as_array()
    x0 = solver.steady.steady_state(1.2, 10.0, solver.Params(mu=np.inf))
    x0[1] = 0.5  # an oscillation about the steady motion (48), on the rim for the whole run

    def augmented(t, y):
        load = load_fn(*y[:4], 0.0, 0.0, pa)
        return [*rolling.rolling_rhs(*y[:4], pa, load), loads.power(load, y[1], y[2], y[3], *_centre_velocity(y))]

    sol = solve_ivp(augmented, (0, 1.0), [*x0, 0.0], method="DOP853", rtol=1e-12, atol=1e-12, dense_output=True)
    ys = sol.sol(np.linspace(0, 1.0, 200))
    E = rolling.energy(ys[0], ys[1], ys[2], ys[3], pa)
    assert (rolling.normal_force(ys[0], ys[1], ys[3], pa) > 0).all()  # on the rim throughout
    assert np.all(np.diff(E) < 0) and E[0] - E[-1] > 1e-4 * abs(E[0])
    np.testing.assert_allclose(E - E[0], ys[4], atol=1e-9 * abs(E[0]))


def _section_states(n, seed):
    rng = np.random.default_rng(seed)
    return np.stack([rng.uniform(0.9, 1.6, n), rng.uniform(-6, 6, n), rng.choice([35.0, 65.0], n),
                     np.full(n, 10.0)], -1)


@pytest.mark.parametrize("names, mu", [(("coulomb_rolling",), np.inf), (("coulomb_drilling",), 1.0),
                                       (("air_drag",), 1.0), (NEW_TERMS, np.inf),
                                       pytest.param(NEW_TERMS, 1.0, marks=pytest.mark.slow)])  # ~45 s compile
def test_a_term_at_zero_strength_gives_the_scene_without_it_bit_for_bit(names, mu):
    """The term's kernel at strength 0 (named in ``terms``) against the conservative scene: every
    output equal, periodic detection included (a term at zero strength does not dissipate). Also the
    kernel of all three terms, which the study dissipation-models runs every model and map through."""
    x = _section_states(40, 7)
    without = solver.simulate(x, solver.Params(mu=mu), t_max=5.0, workers=1, method="dp5")  # the kernel, integrated
    with_zero = solver.simulate(x, solver.Params(mu=mu), t_max=5.0, workers=1, terms=names, method="dp5")
    assert (without["outcome"] == outcomes.PERIODIC_ROLLING).any()
    for key in without:
        np.testing.assert_array_equal(with_zero[key], without[key], err_msg=key)


@pytest.mark.parametrize("name, mu", [("coulomb_rolling", np.inf), ("coulomb_drilling", 1.0), ("air_drag", 1.0)])
def test_the_engine_with_the_term_agrees_with_the_scipy_reference(name, mu):
    _, on = TERMS[name]
    p = solver.Params(mu=mu, **on)
    x = _section_states(8, 11)
    ours = solver.simulate(x, p, t_max=4.0, rtol=1e-10, atol=1e-12, workers=1)
    ref = reference(x, p, t_max=4.0, rtol=1e-10, atol=1e-12)
    assert scenes.scene_of(p).terms == (name,)
    np.testing.assert_array_equal(ours["outcome"], ref["outcome"])
    np.testing.assert_allclose(ours["t_end"], ref["t_end"], rtol=1e-6, atol=1e-6)
    assert not (ours["outcome"] == outcomes.PERIODIC_ROLLING).any()  # dissipative: no periodic detection
    if np.isfinite(mu):
        assert ours["slip_phases"].max() > 0


def test_the_terms_change_the_outcomes():
    """The sizes chosen above are not negligible: each term moves t_end of the fig11 states."""
    x = _section_states(40, 3)
    base = solver.simulate(x, solver.Params(mu=np.inf, k_d=1e-9), t_max=5.0, workers=1)
    for name in ("coulomb_rolling",):
        moved = solver.simulate(x, solver.Params(mu=np.inf, **TERMS[name][1]), t_max=5.0, workers=1)
        assert np.abs(moved["t_end"] - base["t_end"]).max() > 1e-3


def test_the_flight_with_drag_agrees_with_scipy_and_tends_to_the_parabola():
    p0 = solver.Params()
    for _ in range(20):
        beta, w1, w3 = RNG.uniform(0.3, 2.5), RNG.uniform(-10, 10), RNG.uniform(-30, 30)
        u1, u3 = RNG.uniform(-0.2, 0.2), RNG.uniform(-0.2, 0.2)
        pa = p0.replace(rho_air=1.2).as_array()
        ours = flight.landing_distance(beta, w1, w3, u1, u3, pa)
        d, z = kinematics.centre_position(beta, pa)
        v = kinematics.centre_velocity(beta, w1, w3, u1, u3, pa)
        k = air.drag_rate(pa)

        def rhs(t, s, k=k):
            vv = s[3:]
            return [*vv, *(-k * np.linalg.norm(vv) * vv - np.array([0, 0, p0.g]))]

        def ground(t, s):
            return s[2]
        ground.terminal, ground.direction = True, -1
        if z <= 0:
            assert ours == pytest.approx(d, abs=1e-15)
            continue
        sol = solve_ivp(rhs, (0, 10.0), [d, 0.0, z, v[0], v[2], v[1]], method="DOP853", rtol=1e-13, atol=1e-14,
                        events=ground)
        end = sol.y_events[0][0]
        assert ours == pytest.approx(np.hypot(end[0], end[1]), abs=1e-11)
        strong = flight.landing_distance(beta, w1, w3, u1, u3, p0.replace(rho_air=1e5).as_array())
        assert np.isfinite(strong) and abs(strong - d) < abs(ours - d) + 1e-12  # strong drag: lands near d
        parabola = flight.landing_distance(beta, w1, w3, u1, u3, p0.as_array())
        tiny = flight.landing_distance(beta, w1, w3, u1, u3, p0.replace(rho_air=1e-9).as_array())
        assert abs(tiny - parabola) < 1e-9 and abs(ours - parabola) > abs(tiny - parabola)


def test_params_of_the_terms_are_checked():
    with pytest.raises(ValueError, match="c_r"):
        solver.Params(c_r=-1e-3)
    with pytest.raises(ValueError, match="rho_air"):
        solver.Params(rho_air=float("nan"))
    assert solver.Params(c_d=1e-3).dissipative and not solver.Params().dissipative
    with pytest.raises(ValueError, match="c_r=0.5 m must be < r"):
        solver.Params(c_r=0.5)
    with pytest.raises(ValueError, match="unknown terms"):
        solver.simulate(_section_states(2, 1), solver.Params(), terms="no_such_term")
    assert scenes.scene_of(solver.Params(), ("air_drag",)).terms == ("air_drag",)
    assert scenes.scene_of(solver.Params(c_r=1e-3, rho_air=1.2)).name == "slipping+coulomb_rolling+air_drag"
