"""The exact reduced solver of conservative rolling against independent computations.

* its tables of Phi against ``solver.analysis.floquet.fundamental`` (another integration of (62));
* its results against the scipy reference (DOP853 at rtol 1e-12, ``solver.analysis.scipy_reference``) on
  states of the Figs. 11-13 rolling-only sections: random states, turning-point starts (omega1 = 0),
  the steady motion of each section and small orbits around it, runs cut by t_max;
* ``simulate(method="reduced" | "auto")``: the same columns, the choice in ``attrs``, one-line refusals.
"""

from __future__ import annotations

import time

import numpy as np
import pytest

from rimroll import solver
from rimroll.solver.analysis import floquet
from rimroll.solver.analysis.scipy_reference import reference
from rimroll.solver.engine import reduced_simulate, reduced_tables
from rimroll.solver.engine import simulate as simulate_module
from rimroll.solver.engine.outcomes import ON_RIM_AT_T_MAX, PERIODIC_ROLLING, STEADY_MOTION
from rimroll.solver.engine.outputs import OUTPUTS
from rimroll.study.outcome_sections import steady_beta0

P = solver.Params(mu=np.inf)
SECTIONS = (35.0, 65.0, 105.0)  # omega2 [1/s] of Figs. 11, 12, 13; omega3 = 10 1/s


def _states(omega2, n, seed):
    rng = np.random.default_rng(seed)
    beta = rng.uniform(0.8, 1.8, n)
    omega1 = rng.uniform(-6.0, 6.0, n)
    omega1[: n // 8] = 0.0  # turning-point starts
    states = np.stack([beta, omega1, np.full(n, omega2), np.full(n, 10.0)], axis=-1)
    b0 = steady_beta0(omega2, 10.0, P, 0.8, 1.8)
    if b0 is not None:  # the section's steady motion and small orbits around it
        extra = [[b0, 0.0, omega2, 10.0], [b0 + 1e-3, 0.0, omega2, 10.0], [b0 - 2e-2, 0.3, omega2, 10.0]]
        states = np.concatenate([states, extra])
    return states


def test_the_tables_are_the_fundamental_matrix_of_62():
    x, j = P.rho / P.R, P.j
    table = reduced_tables.build(x, j, -2.0, 8.0)
    beta = np.linspace(-1.9, 7.9, 997)
    phi = floquet.fundamental(beta, x, j)
    scale = np.abs(phi).max(axis=(1, 2))
    for f, (a, b) in zip((reduced_tables.PHI11, reduced_tables.PHI12, reduced_tables.PHI21, reduced_tables.PHI22),
                         ((0, 0), (0, 1), (1, 0), (1, 1))):
        err = np.abs(reduced_tables.evaluate(table, beta, f) - phi[:, a, b]) / scale
        assert err.max() < 1e-12
    k = j / (1 + j)
    q12 = k * phi[:, 0, 0] * phi[:, 0, 1] + phi[:, 1, 0] * phi[:, 1, 1]
    assert np.max(np.abs(reduced_tables.evaluate(table, beta, reduced_tables.Q12) - q12) / scale**2) < 1e-12


def test_the_spread_bounds_and_the_node_values_hold_on_every_panel():
    """A panel's function differs from its c_0 by at most its tabled spread (the whole-panel bound that lets the
    march cross a panel without combining its series), and the tabled node values are the series at the
    Gauss-Kronrod nodes."""
    table = reduced_tables.build(P.rho / P.R, P.j, -1.5, 4.7)
    u = np.linspace(-1, 1, 801)
    nodes = reduced_tables.kronrod()[0]
    for i in range(table.values.shape[0]):
        for k, f in enumerate(reduced_tables.SPREAD_FUNCTIONS):
            series = table.values[i, f]
            assert np.abs(np.polynomial.chebyshev.chebval(u, series) - series[0]).max() <= table.spread[i, k]
        for k, f in enumerate(reduced_tables.NODE_FUNCTIONS):
            np.testing.assert_allclose(table.nodes[i, k], np.polynomial.chebyshev.chebval(nodes, table.values[i, f]),
                                       rtol=0, atol=1e-13 * max(1.0, np.abs(table.values[i, f]).sum()))


def test_the_kronrod_rule_and_its_gauss_rule_are_exact_to_their_degrees():
    """The 15-point Kronrod rule integrates x^n exactly for n <= 22, its embedded 7-point Gauss rule for n <= 13;
    both fail one degree beyond (so the embedded estimate |K - G| measures something)."""
    x, wk, wg = reduced_tables.kronrod()
    for n in range(24):
        exact = (1 - (-1) ** (n + 1)) / (n + 1)
        assert (abs(wk @ x**n - exact) < 1e-14) == (n <= 22 or n % 2 == 1)
        assert (abs(wg @ x**n - exact) < 1e-14) == (n <= 13 or n % 2 == 1)
    assert np.count_nonzero(wg) == 7


def test_the_fall_outcome_in_numpy_is_the_engines_rule():
    """``reduced_legs.fall_outcomes`` (numpy, no compile) against ``rules.fall_outcome`` (the engine's compiled
    rule) on separation states all around the rim, both ways of omega1, falling in and out."""
    from rimroll.solver.engine import reduced_legs, rules

    rng = np.random.default_rng(11)
    beta = rng.uniform(-1.5, 4.6, 400)
    omega1, omega3 = rng.uniform(-30, 30, 400), rng.uniform(-40, 40, 400)
    p = P.as_array()
    got = reduced_legs.fall_outcomes(beta, omega1, omega3, p)
    want = [rules.fall_outcome(b, w1, w3, 0.0, 0.0, p) for b, w1, w3 in zip(beta, omega1, omega3)]
    np.testing.assert_array_equal(got, want)
    assert 50 < np.count_nonzero(got == got[0]) < 350  # both outcomes occur


@pytest.mark.parametrize("omega2", SECTIONS)
def test_outcomes_and_times_equal_the_scipy_reference(omega2):
    states = _states(omega2, 48, seed=int(omega2))
    got = reduced_simulate.solve(states, P, t_max=20.0)
    ref = reference(states, P, t_max=20.0, rtol=1e-12, atol=1e-12)
    np.testing.assert_array_equal(got["outcome"], ref["outcome"])
    assert (got["status"] == 0).all()
    err = np.abs(got["t_end"] - ref["t_end"])
    assert np.median(err) <= 1e-11 and err.max() <= 1e-9
    periodic = ref["outcome"] == PERIODIC_ROLLING
    assert periodic.sum() >= 3
    np.testing.assert_allclose(got["half_period"][periodic], ref["half_period"][periodic], rtol=0, atol=1e-9)
    assert np.isnan(got["half_period"][~periodic]).all()
    assert got["energy_drift"].max() < 1e-12  # the end state lies on the level of (60)
    if steady_beta0(omega2, 10.0, P, 0.8, 1.8) is not None:
        assert got["outcome"][-3] == STEADY_MOTION


def test_a_run_cut_by_t_max_ends_where_the_reference_is():
    states = _states(35.0, 24, seed=7)
    got = reduced_simulate.solve(states, P, t_max=0.15)
    ref = reference(states, P, t_max=0.15, rtol=1e-12, atol=1e-12)
    np.testing.assert_array_equal(got["outcome"], ref["outcome"])
    on = got["outcome"] == ON_RIM_AT_T_MAX
    assert on.sum() >= 5
    assert np.all(got["t_end"][on] == 0.15)
    engine = solver.simulate(states[on], P, t_max=0.15, rtol=1e-12, atol=1e-12, method="dop853")
    for name in ("beta_end", "omega1_end", "omega2_end", "omega3_end", "revolutions"):
        np.testing.assert_allclose(got[name][on], engine[name], rtol=0, atol=1e-8)


def test_near_the_separatrix_of_the_top_every_state_ends_within_its_bound():
    """Pendulum states (omega2 = omega3 = 0) with the energy of the unstable top x0+ (46) times 1 +- eps:
    W has a near-double root at beta = pi/2, the time to it grows like log(1/eps). Each ends, quickly,
    as the reference says (the ball turns just below the top, or passes over it, and falls)."""
    beta0 = np.pi / 2 - 0.3
    a = 2 * P.g * P.rho / ((1 + P.j) * P.r**2)
    eps = np.array([-1e-8, 1e-8, -1e-5, 1e-5])
    omega1 = np.sqrt(a * (1 - np.sin(beta0)) * (1 + eps))
    states = np.stack([np.full(4, beta0), omega1, np.zeros(4), np.zeros(4)], axis=-1)
    start = time.perf_counter()
    got = reduced_simulate.solve(states, P, t_max=20.0)
    assert time.perf_counter() - start < 30.0
    ref = reference(states, P, t_max=20.0, rtol=1e-12, atol=1e-12)
    np.testing.assert_array_equal(got["outcome"], ref["outcome"])
    assert (got["status"] == 0).all()
    # the reference's energy drift (~1e-12 relative) moves its level by 1e-12/eps of the distance to the
    # separatrix, and its time by ~that / (2 lambda): 1e-7 relative at eps = 1e-5, 1e-4 at 1e-8
    np.testing.assert_allclose(got["t_end"][2:], ref["t_end"][2:], rtol=1e-7)
    np.testing.assert_allclose(got["t_end"][:2], ref["t_end"][:2], rtol=1e-4)
    # turning just below the top and passing over it take the same time to O(eps) (sin is even about pi/2)
    assert abs(got["t_end"][0] - got["t_end"][1]) < 1e-6
    assert got["t_end"][0] > got["t_end"][2] > 0.5  # closer to the separatrix: longer


def test_simulate_runs_it_on_request_and_by_choice():
    states = _states(65.0, 16, seed=3)
    direct = reduced_simulate.solve(states, P)
    forced = solver.simulate(states, P, method="reduced")
    assert forced.attrs["method"] == "reduced"
    assert set(forced) == {o.name for o in OUTPUTS}
    for name in forced:
        np.testing.assert_array_equal(forced[name], direct[name])
    assert solver.simulate(states, P, method="auto").attrs["method"] == "reduced"
    hybrid = solver.simulate(np.empty((0, 4)), solver.Params(mu=1.0), method="auto")  # no state: no compile
    assert hybrid.attrs["method"] == "dp5" and hybrid["outcome"].shape == (0,)
    assert solver.simulate(np.empty((0, 4)), P).attrs["method"] == "reduced"  # the default is auto
    assert solver.simulate(np.empty((0, 4)), P, method="dp5").attrs["method"] == "dp5"  # every result says its method
    assert [simulate_module.method_used(m, q) for m, q in (("auto", P), ("auto", solver.Params(mu=1.0)),
                                                           ("dop853", P))] == ["reduced", "dp5", "dop853"]


def test_auto_passes_every_option_to_the_integrator_it_falls_back_on():
    """"auto" in a slipping scene runs dp5 with the caller's switching, slip_method included."""
    x = np.array([[1.2, 5.0, 65.0, 10.0], [1.0, -3.0, 65.0, 10.0], [1.4, 0.5, 65.0, 10.0]])
    slip = solver.Params(mu=1.0)
    switching = {"delta": 1e-6, "u_stop": 1e-6, "u_floor": 1e-8, "slip_method": "explicit"}
    auto = solver.simulate(x, slip, t_max=2.0, switching=switching, method="auto", workers=1)
    dp5 = solver.simulate(x, slip, t_max=2.0, switching=switching, method="dp5", workers=1)
    assert auto.attrs["method"] == "dp5"
    for name in dp5:
        np.testing.assert_array_equal(auto[name], dp5[name])


def test_threads_and_shapes_do_not_change_the_answer():
    states = _states(105.0, 24, seed=5)
    one = reduced_simulate.solve(states, P, workers=1)
    grid = reduced_simulate.solve(states[:24].reshape(4, 6, 4), P, workers=3)
    for name in one:
        assert grid[name].shape == (4, 6)
        np.testing.assert_array_equal(grid[name].reshape(-1), one[name][:24])


@pytest.mark.parametrize("params", [solver.Params(mu=1.0), solver.Params(mu=np.inf, k_r=0.1)])
def test_simulate_refuses_a_scene_it_cannot_solve_with_one_line(params):
    with pytest.raises(ValueError, match="method='reduced'") as info:
        solver.simulate(np.array([[1.2, 0.5, 35.0, 10.0]]), params, method="reduced")
    assert "\n" not in str(info.value)


@pytest.mark.slow
@pytest.mark.parametrize("omega2", SECTIONS)
def test_the_whole_rolling_section_equals_the_engine_at_rtol_1e_12(omega2):
    """The full 360 x 240 rolling-only section of Fig. 11, 12 or 13: outcomes equal to the engine's DOP853 at
    rtol 1e-12 on every cell, or the cell is within 1e-9 rad of a boundary of the reduced solver's own map (its
    outcome changes between beta -+ 1e-9) and a tighter engine run (rtol 1e-14) agrees with it; t_end median
    <= 1e-11 s."""
    beta, omega1 = np.linspace(0.8, 1.8, 240), np.linspace(-20.0, 20.0, 360)
    b, w = np.meshgrid(beta, omega1, indexing="ij")
    states = np.stack([b, w, np.full_like(b, omega2), np.full_like(b, 10.0)], -1).reshape(-1, 4)
    got = reduced_simulate.solve(states, P)
    eng = solver.simulate(states, P, rtol=1e-12, atol=1e-14, method="dop853")
    assert (got["status"] == 0).all()
    differ = np.flatnonzero(got["outcome"] != eng["outcome"])
    if differ.size:
        x = states[differ]
        shifted = [reduced_simulate.solve(x + [s, 0, 0, 0], P)["outcome"] for s in (-1e-9, 1e-9)]
        tight = solver.simulate(x, P, rtol=1e-14, atol=1e-16, method="dop853")["outcome"]
        near = (shifted[0] != shifted[1]) | (shifted[0] != got["outcome"][differ])
        assert np.all(near | (tight == got["outcome"][differ])), x[~near & (tight != got["outcome"][differ])]
    same = (got["outcome"] == eng["outcome"]) & (eng["t_end"] > 0)
    assert np.median(np.abs(got["t_end"][same] - eng["t_end"][same])) <= 1e-11


def test_whole_turns_of_beta_change_nothing():
    """beta + 2 pi k is the same state (the equations hold beta only in sin and cos): the same outcome, the same
    times, the end angle shifted by the same whole turns."""
    k = np.array([0, 1, -3, 4, -5, 20])
    states = np.tile([1.2, 0.5, 35.0, 10.0], (len(k), 1))
    states = np.concatenate([states, np.tile([1.05, -2.0, 65.0, 10.0], (len(k), 1))])
    states[:, 0] += 2 * np.pi * np.concatenate([k, k])
    got = reduced_simulate.solve(states, P, t_max=20.0)
    assert (got["status"] == 0).all()
    for half in (slice(0, 6), slice(6, 12)):
        assert (got["outcome"][half] == got["outcome"][half][0]).all()
        np.testing.assert_allclose(got["t_end"][half], got["t_end"][half][0], rtol=1e-12)
        np.testing.assert_allclose(got["beta_end"][half] - 2 * np.pi * k, got["beta_end"][half][0], atol=1e-12)


def test_the_steady_motion_prefilter_gives_the_rules_answer():
    """``reduced_simulate._steady`` evaluates ``rules.on_steady_motion`` only where |omega1| allows a steady motion:
    on random states, each section's steady motion, and states with omega1 at 0.5 to 3 times the rule's tolerance
    there, it answers as the rule does on every state."""
    from rimroll.solver.engine import rules

    p = P.as_array()
    rng = np.random.default_rng(3)
    rows = [np.stack([rng.uniform(0.8, 1.8, 500), rng.uniform(-6, 6, 500), np.full(500, 35.0), np.full(500, 10.0)], -1)]
    for omega2 in SECTIONS:
        b0 = steady_beta0(omega2, 10.0, P, 0.8, 1.8)
        if b0 is not None:
            scale = reduced_simulate._omega_scale(0.0, omega2, 10.0, p)
            for f in (0.0, 0.5, 0.999, 1.0, 1.001, 1.5, 2.0, 3.0):
                rows.append(np.array([[b0, f * rules.STEADY_TOL * scale, omega2, 10.0]]))
    x = np.concatenate(rows)
    b, w1, w2, w3 = x.T
    want = np.asarray(reduced_simulate._on_steady_motion(b, w1, w2, w3, p), dtype=bool)
    assert want.any() and not want.all()
    assert np.array_equal(reduced_simulate._steady(b, w1, w2, w3, p), want)
