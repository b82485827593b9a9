"""solver.simulate: API, validation, status codes, free flight, agreement with scipy."""

import importlib.util
import inspect
import math

import numpy as np
import pytest

from rimroll import solver
from rimroll.solver.analysis.scipy_reference import reference
from rimroll.solver.engine import backends, outcomes, rules
from rimroll.solver.engine.outcomes import FALL_IN, FALL_OUT, ON_RIM_AT_T_MAX
from rimroll.solver.engine.simulate import method_used, simulate
from rimroll.solver.physics import flight, rolling
from rimroll.solver.physics.params import Params
from tests.helpers.bounded_runs import P, assert_finite, sim
from tests.helpers.scipy_agreement import compare_with_scipy

INF = float("inf")
FIELDS = {
    "outcome": np.int8, "t_end": np.float64, "f2_min": np.float64, "half_period": np.float64,
    "revolutions": np.float64, "slip_phases": np.int32, "slip_time": np.float64, "energy_drift": np.float64,
    "n_steps": np.int64, "n_searched": np.int64, "beta_end": np.float64, "omega1_end": np.float64,
    "omega2_end": np.float64, "omega3_end": np.float64, "steady_h": np.float64, "status": np.int8,
    "n_slip_steps": np.int64, "u1_end": np.float64, "u3_end": np.float64,
    "on_rim_reason": np.int8,
}


def fig11_states(n, seed=0):
    """Random states from the Fig. 11-13 sections: beta in [0.8, 1.8], omega1 in [-20, 20]."""
    rng = np.random.default_rng(seed)
    return np.stack([rng.uniform(0.8, 1.8, n), rng.uniform(-20, 20, n), rng.choice([35.0, 65.0, 105.0], n),
                     np.full(n, 10.0)], axis=-1)


# ------------------------------------------------------------------------------------- API


def test_result_fields_shapes_and_dtypes():
    x = fig11_states(6).reshape(2, 3, 4)
    res = simulate(x, Params(mu=INF), t_max=2.0)
    assert set(res) == set(FIELDS)
    for name, dtype in FIELDS.items():
        assert res[name].shape == (2, 3), name
        assert res[name].dtype == dtype, name
    assert set(np.unique(res["outcome"])) <= {0, 1, 2, 3}
    assert np.all(res["status"] == 0)
    assert solver.simulate is simulate
    assert set(solver.OUTCOME_MEANINGS) == {0, 1, 2, 3, 4} and set(solver.STATUS_MEANINGS) == {0, 1, 2, 3, 4, 5}


def test_single_state_gives_scalar_shaped_arrays():
    res = simulate([1.2, 1.0, 35.0, 10.0], Params(mu=INF), t_max=1.0)
    assert res["outcome"].shape == ()


@pytest.mark.parametrize(
    "kwargs,match",
    [
        ({"states": np.zeros((3, 3))}, r"`states` must have last axis 4"),
        ({"states": [[1.0, np.nan, 35.0, 10.0]]}, r"`states` must be finite"),
        ({"rtol": 0.0}, r"`rtol` must be in \[1e-14, 0.01\]"),
        ({"rtol": -1e-8}, r"`rtol` must be in \[1e-14, 0.01\]"),
        ({"rtol": 1.0}, r"`rtol` must be in \[1e-14, 0.01\]"),
        ({"rtol": 1e-300}, r"`rtol` must be in \[1e-14, 0.01\]"),
        ({"atol": 2.0}, r"`atol` must be in \(0, 1\]"),
        ({"atol": 0.0}, r"`atol` must be > 0"),
        ({"t_max": 0.0}, r"`t_max` must be > 0"),
        ({"t_max": INF}, r"`t_max` must be finite"),
        ({"method": "rk4"}, r"`method` must be one of \['dop853', 'dp5'\]"),
        ({"max_steps": 0}, r"`max_steps` must be an integer >= 1"),
        ({"max_switches": -1}, r"`max_switches` must be an integer >= 0"),
        ({"params": {"mu": 1.0}}, r"`params` must be a solver.Params"),
        ({"switching": {"delta": -1.0}}, r"switching tolerance `delta` must be a positive"),
        ({"switching": {"eps": 1.0}}, r"unknown switching tolerance `eps`"),
    ],
)
def test_bad_arguments_raise_value_error_naming_them(kwargs, match):
    args = {"states": [[1.2, 1.0, 35.0, 10.0]], "params": Params(mu=INF)}
    args.update(kwargs)
    with pytest.raises(ValueError, match=match):
        simulate(args.pop("states"), args.pop("params"), **args)


def test_the_default_method_is_auto_and_cuda_gets_the_integrator(monkeypatch):
    """``simulate``'s default method is "auto": the exact solver in the conservative rolling-only scene on the
    CPU, dp5 in any other scene and with backend="cuda" (the exact solver runs on the CPU), so a missing
    device extra is reported, not run around; a bad backend name is one line whichever method would run."""
    roll = Params(mu=INF)
    assert inspect.signature(simulate).parameters["method"].default == "auto"
    assert [method_used("auto", roll), method_used("auto", roll, backend="cuda"), method_used("auto", P),
            method_used("auto", roll, terms=("air_drag",))] == ["reduced", "dp5", "dp5", "dp5"]
    x = [[1.2, 1.0, 35.0, 10.0], [1.1, 2.0, 35.0, 10.0]]
    default, exact = simulate(x, roll, t_max=1.0, workers=1), simulate(x, roll, t_max=1.0, workers=1, method="reduced")
    assert default.attrs["method"] == "reduced"
    for name in exact:
        np.testing.assert_array_equal(default[name], exact[name], err_msg=name)
    real = importlib.util.find_spec
    monkeypatch.setattr(backends.importlib.util, "find_spec",
                        lambda name, *a: None if name == "numba_cuda" else real(name, *a))
    with pytest.raises(backends.BackendUnavailable, match=r"rimroll\[gpu\]"):
        simulate(x, roll, t_max=1.0, backend="cuda")
    with pytest.raises(ValueError, match="method='reduced': the reduced solver runs on the CPU; got backend='cuda'"):
        simulate(x, roll, t_max=1.0, backend="cuda", method="reduced")
    for method in ("auto", "reduced", "dp5"):
        with pytest.raises(ValueError, match="`backend` must be one of cpu, cuda, auto; got 'gpu'") as info:
            simulate(x, roll, t_max=1.0, backend="gpu", method=method)
        assert "\n" not in str(info.value)


@pytest.mark.parametrize("method", ["dp5", "auto"])
def test_whole_turns_of_beta_change_nothing(method):
    """beta is an angle (the equations hold it only in sin and cos): beta + 2 pi k is the same state, so the
    outcome and t_end must not change (make-probability with a wide spread in beta draws such states)."""
    k = np.array([0, 1, -3, 4, -5, 20])
    x = np.tile([1.2, 0.5, 35.0, 10.0], (len(k), 1))
    x[:, 0] += 2 * np.pi * k
    r = simulate(x, Params(mu=INF), t_max=20.0, rtol=1e-6, atol=1e-9, method=method, workers=1)
    assert (r["status"] == 0).all(), r["status"]
    assert (r["outcome"] == r["outcome"][0]).all(), r["outcome"]
    np.testing.assert_allclose(r["t_end"], r["t_end"][0], rtol=1e-6)


# ------------------------------------------------------------------------------ status codes


def test_status_max_steps_is_recorded_not_raised():
    x = np.array([[1.2, 0.5, 35.0, 10.0], [1.0, 15.0, 35.0, 10.0]])
    res = simulate(x, Params(mu=INF), t_max=20.0, max_steps=3, method="dp5")  # the integrator's step budget
    assert res["status"][0] == 1 and res["outcome"][0] == ON_RIM_AT_T_MAX and res["n_steps"][0] == 3
    assert res["status"][1] == 0  # the neighbour (falls at t = 0) is unaffected


def test_status_non_finite_for_a_huge_state():
    x = np.array([[1.2, 1e200, 35.0, 10.0], [1.2, 0.5, 35.0, 10.0]])
    res = simulate(x, Params(mu=INF), t_max=0.5, method="dp5")  # the integrator's non-finite check
    assert res["status"][0] == 3
    assert res["status"][1] == 0 and res["outcome"][1] == ON_RIM_AT_T_MAX


def test_status_too_many_switches():
    # outside the friction cone at t = 0 (mu small): the first switch already exceeds a cap of 0
    p = Params(mu=0.05)
    x = [[1.2, 0.5, 35.0, 10.0]]
    res = simulate(x, p, t_max=0.5, max_switches=0)
    assert res["status"][0] == 4
    assert simulate(x, p, t_max=0.5)["status"][0] == 0


# -------------------------------------------------------------------------------- free flight


def test_flight_landing_time_closed_form():
    g = 9.81
    for z, vz in [(0.1, 0.0), (0.1, 2.0), (0.1, -2.0), (0.0, 1.0), (-0.05, -1.0)]:
        t = flight.landing_time(z, vz, g)
        if z <= 0:
            assert t == 0.0
        else:
            assert z + vz * t - g * t * t / 2 == pytest.approx(0.0, abs=1e-15)
            assert vz - g * t < 0  # descending


def test_flight_in_and_out_by_position():
    p = Params()
    a = p.as_array()
    # at rest on top of the rim's tube, slightly inside / outside: drops straight down
    assert rules.fall_outcome(math.pi / 2 - 0.01, 0.0, 0.0, 0.0, 0.0, a) == FALL_IN
    assert rules.fall_outcome(math.pi / 2 + 0.01, 0.0, 0.0, 0.0, 0.0, a) == FALL_OUT
    # from outside-above, rolling inwards over the top: too slow lands outside, fast enough inside,
    # much too fast overshoots the whole rim (distance from the axis is again > R)
    beta = 2.5
    assert rules.fall_outcome(beta, -5.0, 0.0, 0.0, 0.0, a) == FALL_OUT
    assert rules.fall_outcome(beta, -8.0, 0.0, 0.0, 0.0, a) == FALL_IN
    assert rules.fall_outcome(beta, -40.0, 0.0, 0.0, 0.0, a) == FALL_OUT
    # closed form of one case: x = d + v_rad t, y = v_tan t at the landing time
    w1, w3 = -8.0, 10.0
    bd = p.r * w1 / p.rho
    vz = bd * p.rho * math.cos(beta)
    z = p.rho * math.sin(beta)
    t = (vz + math.sqrt(vz * vz + 2 * p.g * z)) / p.g
    d = p.R - p.rho * math.cos(beta) + bd * p.rho * math.sin(beta) * t
    assert flight.landing_distance(beta, w1, w3, 0.0, 0.0, a) == pytest.approx(math.hypot(d, p.r * w3 * t), rel=1e-14)


def test_fall_at_t0_when_f2_negative():
    p = Params(mu=INF)
    x = np.array([1.0, 15.0, 35.0, 10.0])
    assert rolling.normal_force(x[0], x[1], x[3], p.as_array()) < 0
    res = simulate(x[None], p)
    assert res["t_end"][0] == 0.0 and res["n_steps"][0] == 0
    assert res["outcome"][0] == rules.fall_outcome(x[0], x[1], x[3], 0.0, 0.0, p.as_array())


def test_fall_event_state_has_f2_at_zero():
    p = Params(mu=INF)
    res = simulate(fig11_states(40, seed=3), p, t_max=5.0)
    fell = (res["outcome"] <= FALL_OUT) & (res["t_end"] > 0)
    assert fell.any()
    f2 = rolling.normal_force.py_func(res["beta_end"], res["omega1_end"], res["omega3_end"], p.as_array())
    assert np.all(np.abs(f2[fell]) < 1e-9)
    assert np.all(res["f2_min"][fell] <= 1e-9)


# -------------------------------------------------------------------------- against scipy


@pytest.mark.parametrize("k_r,k_d", [(0.0, 0.0), (0.02, 0.0), (0.0, 0.02)])
def test_outcomes_match_scipy_dop853(k_r, k_d):
    x = fig11_states(120, seed=11)
    ours, ref, _ = compare_with_scipy(x, Params(mu=INF, k_r=k_r, k_d=k_d), t_max=10.0)
    assert len(np.unique(ref["outcome"])) >= 2  # the sample is not trivial


def test_dop853_method_matches_scipy():
    compare_with_scipy(fig11_states(60, seed=5), Params(mu=INF), t_max=10.0, method="dop853", rtol=1e-10,
                       atol=1e-12)


@pytest.mark.slow
@pytest.mark.parametrize("k_r,k_d", [(0.0, 0.0), (0.02, 0.0), (0.0, 0.02)])
def test_outcomes_match_scipy_dop853_large(k_r, k_d):
    compare_with_scipy(fig11_states(1500, seed=12), Params(mu=INF, k_r=k_r, k_d=k_d), t_max=20.0)


def test_physical_grazing_dip_missed_by_step_end_checks(monkeypatch):
    """F2 dips below 0 for a moment inside one step (a near-deadlock orbit, Sect. 5.1).

    scipy's step-end sign check (the reference without its search of F2's minima) misses it at
    rtol 1e-11 and lets the ball roll on to a later fall; the engine decides the fall at the
    minimum of F2 inside the step and finds the first crossing from rtol 1e-6 down.
    """
    import rimroll.solver.analysis.scipy_reference as ref_mod

    p = Params(mu=INF)
    x = np.array([0.92222377, 10.59047305, 65.0, 10.0])
    ours = [simulate(x, p, rtol=r, atol=r * 1e-2, method="dp5")["t_end"] for r in (1e-6, 1e-7, 1e-8, 1e-10)]
    assert abs(ours[0] - ours[-1]) < 1e-4 * ours[-1]  # the same crossing, to the accuracy of rtol 1e-6
    assert np.ptp(ours[1:]) < 1e-8
    assert reference(x, p)["t_end"] == pytest.approx(ours[-1], rel=1e-8)  # the reference searches minima too
    monkeypatch.setattr(ref_mod, "_first_dip", lambda *args: None)
    naive = ref_mod.reference_one(x, p)  # step ends only
    assert naive["t_end"] > 5 * ours[-1]


def test_threads_deal_states_in_turn_and_every_state_gets_its_own_result():
    """Chunks interleave the states (costly neighbours spread over threads); the results are the
    single-thread ones, row for row, for a state count that does not divide evenly."""
    rng = np.random.default_rng(3)
    x = np.stack([rng.uniform(0.9, 1.6, 203), rng.uniform(-8, 8, 203), np.full(203, 65.0), np.full(203, 10.0)], -1)
    p = solver.Params(mu=1.0)
    one = solver.simulate(x, p, t_max=2.0, workers=1)
    many = solver.simulate(x, p, t_max=2.0, workers=3)
    for name in ("outcome", "status", "n_steps", "t_end", "f2_min", "slip_phases"):
        np.testing.assert_array_equal(many[name], one[name], err_msg=name)


@pytest.mark.parametrize("mu", [float("inf"), 1.0])
def test_very_large_omega2(mu):
    """omega2 = 1000 1/s (stiff-ish fast rotation): no NaN, within budget, and the conservative
    rolling energy drift stays at the tolerance level."""
    p = P.replace(mu=mu)
    w1 = np.array([0.0, 1.0, 5.0, -5.0])
    states = np.stack([np.full(4, 1.0), w1, np.full(4, 1000.0), np.full(4, 10.0)], -1)
    r = sim(states, p, t_max=2.0, max_steps=500_000, method="dp5")  # the integrator's budget and drift
    assert (r["status"] == outcomes.OK).all(), r["status"]
    assert_finite(r)
    rolled = r["slip_phases"] == 0
    assert (r["energy_drift"][rolled] < 1e-6).all(), r["energy_drift"]
