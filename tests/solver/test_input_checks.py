"""Input checks of the public solver API: ``solver.simulate``, ``solver.steady``, ``solution_types``,
``reduced``. A bad argument raises ValueError (TypeError for a ``p`` that is not a Params in the
analysis functions) with a message naming it; valid arguments give the same results as before the
checks (computed here by other routes to the same numbers)."""

from __future__ import annotations

import numpy as np
import pytest

from rimroll import solver
from rimroll.solver.analysis import reduced, steady
from rimroll.solver.analysis import solution_types as st
from rimroll.solver.engine.simulate import MAX_WORKERS, simulate

P = solver.Params()
ROLL = solver.Params(mu=np.inf)
X = [[1.2, 1.0, 35.0, 10.0]]


# ------------------------------------------------------------------------------ simulate: bad input
@pytest.mark.parametrize(
    "kwargs,match",
    [
        ({"max_steps": 10**20}, r"`max_steps` must be an integer >= 1 and <= 2\*\*63 - 1 \(int64\); got 10{20}"),
        ({"max_switches": 2**63}, r"`max_switches` must be an integer >= 0 and <= 2\*\*63 - 1"),
        ({"max_steps": 1e6}, r"`max_steps` must be an integer >= 1"),
        ({"terms": 5}, r"`terms` must be a term's name or a sequence of names \(str\); got 5"),
        ({"terms": [5]}, r"`terms` must be .*; got \[5\]"),
        ({"terms": {"drilling": 1}}, r"`terms` must be .*; got \{'drilling': 1\}"),
        ({"switching": [1]}, r"`switching` must be None or a dict .*; got list \[1\]"),
        ({"switching": {"delta": "1e-3"}}, r"`switching\['delta'\]` must be a real number .*; got '1e-3'"),
        ({"switching": {"slip_method": ["rodas4"]}}, r"switching `slip_method` must be one of"),
        ({"method": ["dp5"]}, r"`method` must be one of"),
        ({"states": [[1, 2, 3, 4], [1, 2]]}, r"`states` must be an array_like of real numbers of one shape"),
        ({"states": np.array(["a", "b", "c", "d"])}, r"`states` must hold real numbers .*; got strings"),
        ({"states": "abcd"}, r"`states` must hold real numbers .*; got strings"),
        ({"states": np.array([1.2, 0, 65, 10], dtype=complex)}, r"`states` must hold real numbers .*; got complex"),
        ({"states": np.array([True, False, True, True])}, r"`states` must hold real numbers .*; got bool"),
        ({"states": np.array([1.2, 0, 65, None])}, r"`states` must hold .*None \(NoneType, not a number\)"),
        ({"states": [[1.2, 0, 65, np.inf]]}, r"`states` must be finite; got inf at index \(0, 3\)"),
        ({"t_max": "1"}, r"`t_max` must be a real number .*; got '1'"),
        ({"t_max": True}, r"`t_max` must be a real number"),
        ({"t_max": 1 + 0j}, r"`t_max` must be a real number"),
        ({"t_max": np.nan}, r"`t_max` must be a real number, not NaN"),
        ({"rtol": "1e-6"}, r"`rtol` must be a real number \(in \[1e-14, 0.01\]\); got '1e-6'"),
        ({"atol": None}, r"`atol` must be a real number"),
        ({"workers": 10**6}, rf"`workers` must be an integer >= 1 and <= {MAX_WORKERS}; got 1000000"),
        ({"workers": 0}, r"`workers` must be an integer >= 1"),
        ({"workers": 2.0}, r"`workers` must be an integer >= 1"),
    ],
)
def test_simulate_refuses_bad_input_naming_it(kwargs, match):
    args = {"states": X, "params": ROLL, "t_max": 0.5}
    args.update(kwargs)
    with pytest.raises(ValueError, match=match):
        simulate(args.pop("states"), args.pop("params"), **args)


def test_workers_cap_is_the_command_lines():
    from rimroll.study import checks

    assert checks.MAX_WORKERS is MAX_WORKERS  # one number, not a copy kept equal


# ------------------------------------------------------------------------------ simulate: valid input unchanged
def test_simulate_gives_the_same_results_for_every_spelling_of_valid_input():
    x = np.array([steady.steady_state(1.2, 10.0, ROLL), [1.2, 0.0, 30.0, 10.0], [0.5, 2.0, 5.0, 5.0],
                  [1.0, 0.0, 0.0, 65.0]])
    ref = simulate(x, ROLL, t_max=2.0, rtol=1e-8, workers=1)
    variants = [
        simulate(x.tolist(), ROLL, t_max=2, rtol=np.float64(1e-8), workers=np.int64(2)),
        simulate(x.astype(object), ROLL, t_max=np.array(2.0), rtol=1e-8, workers=3, max_steps=np.int32(10**6)),
        simulate(x, ROLL, t_max=2.0, switching=None, terms=None, max_switches=10_000),
    ]
    for res in variants:
        assert set(res) == set(ref)
        for name in ref:
            np.testing.assert_array_equal(res[name], ref[name], err_msg=name)
    np.testing.assert_array_equal(ref["outcome"][0], solver.engine.outcomes.STEADY_MOTION)


def test_simulate_with_integer_states_equals_float_states():
    xi = np.array([[1, 0, 30, 10], [1, 2, 5, 5]], dtype=np.int32)
    a, b = simulate(xi, ROLL, t_max=1.0), simulate(xi.astype(float), ROLL, t_max=1.0)
    for name in a:
        np.testing.assert_array_equal(a[name], b[name], err_msg=name)


# ------------------------------------------------------------------------------ analysis: bad input
STATE = steady.steady_state(1.2, 10.0, ROLL)


@pytest.mark.parametrize(
    "call,error,match",
    [
        (lambda: steady.realisable_region(1.0, 10, P, v_throw=-1), ValueError, r"`v_throw` must be .*>= 0.*got -1"),
        (lambda: steady.realisable_region(1.0, 10, P, v_throw=np.nan), ValueError, r"`v_throw` must be .*not NaN"),
        (lambda: steady.realisable_region(1.0, 10, P, v_throw="3"), ValueError, r"`v_throw` must be a real number"),
        (lambda: steady.realisable(1.0, 10, P, 10.0, mu=-0.5), ValueError, r"`mu` must be .*>= 0.*got -0.5"),
        (lambda: steady.rolls_without_slipping(1.0, 10, P, mu=-1), ValueError, r"`mu` must be .*>= 0.*got -1"),
        (lambda: steady.rolls_without_slipping(1.0, 10, P, mu=np.nan), ValueError, r"`mu` must be .*not NaN"),
        (lambda: steady.rolls_without_slipping(1.0, 10, P, mu="1"), ValueError, r"`mu` must be a real number"),
        (lambda: steady.rolls_without_slipping(1.0, 10, {}), TypeError, r"`p` must be a rimroll.solver.Params"),
        (lambda: steady.stays_on_rim(1.0, 10, None), TypeError, r"`p` must be a rimroll.solver.Params"),
        (lambda: steady.steady_state(1, 10, {}), TypeError, r"`p` must be a rimroll.solver.Params .*got dict"),
        (lambda: steady.stability(1, 10, {"j": 1}), TypeError, r"`p` must be a rimroll.solver.Params"),
        (lambda: steady.omega20(1, 10, {}), TypeError, r"`p` must be a rimroll.solver.Params"),
        (lambda: steady.beta_star({}), TypeError, r"`p` must be a rimroll.solver.Params"),
        (lambda: steady.minimal_throw_speed(7, P), ValueError, r"`region` must be REGION_A .*got 7"),
        (lambda: steady.minimal_throw_speed(steady.REGION_A, P, n=2), ValueError, r"`n` must be an integer >= 3"),
        (lambda: st.solution_type(STATE, ROLL, t_max=-1), ValueError, r"`t_max` must be > 0; got -1"),
        (lambda: st.solution_type(STATE, ROLL, t_max="5"), ValueError, r"`t_max` must be a real number"),
        (lambda: st.solution_type([[1, 0, 2, 3], [1, 2]], ROLL), ValueError, r"`states` must be an array_like"),
        (lambda: st.solution_type(STATE, ROLL, rtol=0), ValueError, r"`rtol` must be in \[1e-14, 0.01\].*got 0"),
        (lambda: st.solution_type(STATE, ROLL, atol=-1), ValueError, r"`atol` must be > 0; got -1"),
        (lambda: st.solution_type(STATE, ROLL, eq_tol=-1), ValueError, r"`eq_tol` must be .*0 <= eq_tol < 1.*got -1"),
        (lambda: st.solution_type(STATE, ROLL, eq_tol=np.nan), ValueError, r"`eq_tol` must be .*not NaN"),
        (lambda: st.solution_type(STATE, {}), TypeError, r"`p` must be a rimroll.solver.Params"),
        (lambda: st.classify(STATE, ROLL, connection_tol=0), ValueError, r"`connection_tol` must be > 0"),
        (lambda: st.classify(STATE, ROLL, return_tol=-1e-3), ValueError, r"`return_tol` must be > 0"),
        (lambda: st.equilibrium_kind(STATE, ROLL, eq_tol=2), ValueError, r"`eq_tol` must be"),
        (lambda: reduced.state_on_level(0.1, 0.0, [1.0, 2.0, 3.0], ROLL), ValueError, r"`P` must be the level"),
        (lambda: reduced.state_on_level(0.1, 0.0, [1.0, 2.0], "p"), TypeError, r"`p` must be a rimroll.solver.Params"),
        (lambda: reduced.equilibrium([1.0, 2.0], "a", ROLL), ValueError, r"`beta_guess` must be a real number"),
    ],
)
def test_analysis_refuses_bad_input_naming_it(call, error, match):
    with pytest.raises(error, match=match):
        call()


def test_solution_type_with_rtol_zero_raises_before_scipy_warns(recwarn):
    with pytest.raises(ValueError, match="`rtol`"):
        st.solution_type(STATE, ROLL, rtol=0)
    assert not recwarn.list


# ------------------------------------------------------------------------------ analysis: valid input unchanged
B, W = np.meshgrid(np.linspace(-np.pi, np.pi, 41), np.linspace(-30.0, 30.0, 31), indexing="ij")


def test_steady_state_of_nan_is_nan_and_maps_keep_their_shape():
    np.testing.assert_array_equal(steady.steady_state(np.nan, 10, P), [np.nan, 0.0, np.nan, 10.0])
    b, w = B.copy(), W.copy()
    b[0, 0], w[1, 1] = np.nan, np.inf
    with np.errstate(invalid="ignore", divide="ignore"):
        x = steady.steady_state(b, w, P)
        expected = np.stack([b, np.zeros_like(b), steady.omega20(b, w, P), w], axis=-1)
    assert x.shape == b.shape + (4,)
    np.testing.assert_array_equal(x, expected)
    assert steady.realisable_region(np.nan, 10.0, P, 10.0) == steady.REGION_NONE


def test_realisable_region_is_its_definition():
    for v_throw, mu in ((10.0, None), (3, 0.5), (np.inf, np.inf), (np.float64(10.0), np.float64(1.0))):
        with np.errstate(invalid="ignore", divide="ignore"):
            ok = ((steady.stability(B, W, P) < 0) & steady.rolls_without_slipping(B, W, P, mu)
                  & (steady.throw_speed(B, W, P) <= v_throw))
        expected = np.where(ok, steady.region_of(B), steady.REGION_NONE).astype(np.int8)
        np.testing.assert_array_equal(steady.realisable_region(B, W, P, v_throw, mu), expected)


def test_rolls_without_slipping_takes_mu_as_int_float_or_numpy():
    F1, F2, F3 = steady.contact_forces(B, W, P)
    expected = 1.0 * F2 >= np.hypot(F1, F3)
    for mu in (None, 1, 1.0, np.float64(1.0), np.int64(1), np.array(1.0)):
        np.testing.assert_array_equal(steady.rolls_without_slipping(B, W, P, mu), expected)
    np.testing.assert_array_equal(steady.stays_on_rim(B, W, P), F2 >= 0)


def test_solution_type_is_classify_type_on_valid_states():
    states = np.array([STATE, steady.trivial_state(1, 5.0, ROLL), [0.3, 0.0, 0.0, 0.0], [0.3, 12.0, 0.0, 0.0]])
    types = st.solution_type(states, ROLL, t_max=5.0)
    np.testing.assert_array_equal(types, st.classify(states.tolist(), ROLL, t_max=5, eq_tol=st.DEFAULT_EQ_TOL)["type"])
    assert types[0] == st.NONTRIVIAL_EQUILIBRIUM and types[1] == st.TRIVIAL_EQUILIBRIUM
    assert types[3] == st.NON_PERIODIC_PENDULUM
    np.testing.assert_array_equal(st.equilibrium_kind(states, ROLL, eq_tol=0), st.equilibrium_kind(states, ROLL, 0.0))


def test_state_on_level_takes_the_level_as_a_list_or_an_array():
    beta = np.linspace(-1.0, 1.0, 5)
    x = reduced.state_on_level(beta, 0.5, [3.0, 10.0], ROLL)
    z = reduced.spins(beta, np.array([3.0, 10.0]), ROLL)
    np.testing.assert_array_equal(x, np.stack([beta, np.full(5, 0.5), z[:, 0], z[:, 1]], axis=-1))


def test_a_non_finite_state_is_undetermined_and_the_others_are_classified():
    """classify maps over many states: a NaN or inf state is type 0 (undetermined), documented, and does
    not stop the others (the solution-types study's samples)."""
    both = st.solution_type(np.array([[np.nan, 0, 65, 10], STATE]), ROLL)
    assert both[0] == st.UNDETERMINED and both[1] == st.solution_type(STATE, ROLL)


def test_a_bool_among_ints_is_not_a_number():
    """numpy makes [True, 0, 65, 10] an int array: the list is looked at, as an all-bool one is refused."""
    with pytest.raises(ValueError, match="`states` must hold real numbers .*got a bool"):
        solver.simulate([[True, 0, 65, 10]], ROLL)
