"""Derived parameters are checked with the settings, before any work (``Study.check``).

dissipation-models sets each model's parameters from one strength, k_equivalent: a Coulomb arm
(c_r, c_d) beyond the ball's radius is refused at once, naming the largest strength the ball allows,
computed here independently from the models' equivalence factors; every value of a sweep counts.
"""

from __future__ import annotations

import time

import pytest

from rimroll import solver
from rimroll.study import registry
from rimroll.study.plan import make_plan
from rimroll.study.registry import UserError
from rimroll.workflows import dissipation


def _bound(p: solver.Params) -> float:
    """The largest k_equivalent [1/s] at which every Coulomb arm k x factor stays below r."""
    factors = dissipation.equivalence(p.replace(mu=1.0))
    return min(p.r / factors[key] for key in ("c_r", "c_d"))


@pytest.mark.parametrize("r", [0.10, 0.12, 0.14])
@pytest.mark.parametrize("swept", [False, True])
def test_a_strength_beyond_the_ball_is_refused_before_any_work(r, swept):
    study = registry.get("dissipation-models")
    bound = _bound(solver.Params(r=r))
    for k, ok in ((0.99 * bound, True), (1.01 * bound, False), (10.0, False)):
        sets = {"r": r, "k_equivalent": (0.0, k) if swept else k, "omega2": 35}
        start = time.perf_counter()
        if ok:
            make_plan(study, True, sets)
            continue
        with pytest.raises(UserError, match=r"every model needs k_equivalent < ([0-9.]+) 1/s") as info:
            make_plan(study, True, sets)
        assert time.perf_counter() - start < 10.0  # before any simulation
        stated = float(str(info.value).split("k_equivalent < ")[1].split(" ")[0])
        assert stated == pytest.approx(bound, rel=1e-3)
        assert "\n" not in str(info.value)


def test_every_study_check_sees_its_defaults_valid():
    """A study's own defaults and --quick settings pass its check (the check refuses only what is impossible)."""
    for name in registry.names():
        study = registry.get(name)
        if study.check is not None:
            make_plan(study)
            make_plan(study, quick=True)
