"""Settings and arguments that contradict or make no sense are refused in one line, before any work.

Ordered pairs: every ``*_min``/``*_max`` pair of every study (from the setting table and the study's
own settings, ``setting_table.ordered_pairs``), given reversed and equal. Set-like arguments: one rule
(``solver._arguments.one_of``), tried with every value near the allowed ones. The cases are generated.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

import rimroll
from rimroll.solver import Params
from rimroll.solver._arguments import one_of
from rimroll.solver.analysis import solution_types, steady, trajectory
from rimroll.study import registry
from rimroll.study.plan import make_plan
from rimroll.study.registry import UserError
from rimroll.study.setting_table import MAY_BE_EQUAL, ORDERED, TABLE, ordered_pairs


def _pairs() -> list:
    """(study, low, high, strict) of every ordered pair among each study's settings."""
    return [(name, low, high, strict) for name in registry.names()
            for low, high, strict in ordered_pairs(registry.get(name).settings)]


def test_the_table_orders_every_min_max_pair_it_declares():
    mins = {n[:-4] for n in TABLE if n.endswith("_min")} & {n[:-4] for n in TABLE if n.endswith("_max")}
    assert {(f"{s}_min", f"{s}_max") for s in mins} == {(lo, hi) for lo, hi, _ in ORDERED}
    assert len(_pairs()) >= 8  # beta (fig11-13, continuation, dissipation, predictability ...), beta0, rtol


@pytest.mark.parametrize("name,low,high,strict", _pairs())
def test_a_reversed_or_equal_pair_is_refused_before_any_work(name, low, high, strict):
    settings = registry.get(name).settings
    a, b = float(settings[low]), float(settings[high])
    assert a < b, f"{name}: the defaults {low}={a}, {high}={b} are out of order"
    cases = {"reversed": (b, a), "above": (b, (a + b) / 2)}  # values within the defaults: in range
    if strict:
        cases["equal"] = (a, a)
    for what, (lo, hi) in cases.items():
        with pytest.raises(UserError, match=rf"{low}=.* and {high}=.* out of order") as info:
            make_plan(registry.get(name), True, {low: lo, high: hi})
        assert "\n" not in str(info.value), what
        with pytest.raises(UserError, match="out of order"):
            rimroll.run(name, quick=True, **{low: lo, high: hi})
    if not strict:
        assert low[:-4] in MAY_BE_EQUAL
        make_plan(registry.get(name), True, {low: a, high: a})


@pytest.mark.parametrize("allowed", [(1, -1), (True, False), ("cpu", "cuda")])
def test_one_of_takes_the_allowed_values_and_refuses_their_neighbours(allowed):
    near = [0, 2, -2, 0.5, math.nan, math.inf, None, "1", "yes", 1j, b"cpu", "CPU", "", True, False, 1, -1, 1.0]
    for value in [*allowed, *near]:
        ok = any((type(value) is bool) == (type(a) is bool) and value == a and
                 isinstance(value, str) == isinstance(a, str) for a in allowed)
        if ok:
            assert one_of("x", value, allowed) == value
        else:
            with pytest.raises(ValueError, match=r"`x` must be .* got"):
                one_of("x", value, allowed)


@pytest.mark.parametrize("sign", [0, 2, -2, 0.5, math.nan, math.inf, True, "1", None, np.array([1, 0])])
def test_trivial_state_takes_a_sign(sign):
    with pytest.raises(ValueError, match="`sign` must be 1 or -1"):
        steady.trivial_state(sign, 35.0, Params())


@pytest.mark.parametrize("bad", [math.nan, math.inf, -math.inf])
@pytest.mark.parametrize("where", [0, 1, 2])
def test_a_nonfinite_time_has_no_state(bad, where):
    t_eval = [0.0, 0.5, 1.0]
    t_eval[where] = bad
    with pytest.raises(ValueError, match="`t_eval` must be finite"):
        trajectory.rolling_trajectory([0.5, 0.0, 60.0, 10.0], Params(), t_eval)


@pytest.mark.parametrize("bad", [math.nan, math.inf, -math.inf])
@pytest.mark.parametrize("component", range(4))
def test_a_nonfinite_state_is_undetermined(bad, component):
    """Whatever the component, a state with NaN or inf gets no type (0), whatever the early tests say."""
    state = [np.pi / 2, 0.0, 0.0, 0.0]  # x0+: an equilibrium, were it finite
    state[component] = bad
    rotating = [0.5, bad, 0.0, 0.0]  # omega1 = inf in the pendulum plane: 'rotating' by its energy
    types = solution_types.solution_type([state, rotating], Params(), t_max=1.0)
    assert types.tolist() == [solution_types.UNDETERMINED, solution_types.UNDETERMINED]


@pytest.mark.parametrize("lazy", ["no", "yes", 0, 1, None, "False"])
def test_open_takes_a_flag(lazy, tmp_path):
    with pytest.raises(UserError, match="lazy must be True or False"):
        rimroll.open(tmp_path / "any.nc", lazy=lazy)
