"""The heyoka model of the rolling-only scene (rimroll.peer_models.heyoka_rolling), the peer of
benchmarks/peers.py and of the work-precision study: its equations and rules are rimroll's.

Skipped where heyoka is not installed (it is the optional extra rimroll[bench]; CI does not install it).
"""

import numpy as np
import pytest

from rimroll import solver
from rimroll.peer_models import heyoka_rolling

pytestmark = pytest.mark.skipif(not heyoka_rolling.available(),
                                reason="heyoka is not installed (the optional extra rimroll[bench])")

ROLLING = solver.Params(mu=float("inf"))
OTHER = solver.Params(mu=float("inf"), r=0.11, R=0.23, a=0.012, m=0.55, j=0.6, g=9.7)


@pytest.mark.parametrize("params", [ROLLING, OTHER], ids=["table1", "other"])
def test_rates_and_normal_force_are_rimrolls_to_1e_12(params):
    """At 300 random states heyoka's compiled rates and F2 equal rolling_rhs, alpha_rate and normal_force
    to 1e-12 relative, and the rules applied around heyoka give the answers of solver.engine.rules."""
    report = heyoka_rolling.check_against_rimroll(params)
    assert max(v for k, v in report.items() if k.startswith("rel_diff")) <= 1e-12
    assert report["steady_states_checked"] > 0 and report["transversal_false_checked"] > 0  # both sides met


def test_a_wrong_model_is_caught(monkeypatch):
    monkeypatch.setattr(heyoka_rolling, "f2_over_m", lambda b, w1, w3, c, sin, cos: c.g * sin(b))
    with pytest.raises(ValueError, match="rel_diff_F2"):
        heyoka_rolling.check_against_rimroll(ROLLING, n=50)


def test_scenes_that_slip_or_dissipate_are_refused_with_the_reason():
    assert heyoka_rolling.unsupported(ROLLING) is None
    assert "slips" in heyoka_rolling.unsupported(solver.Params(mu=1.0))
    assert "dissipates" in heyoka_rolling.unsupported(solver.Params(mu=float("inf"), k_r=0.02))
    with pytest.raises(ValueError, match="slips"):
        heyoka_rolling.Integrator(solver.Params(mu=1.0), 1e-8)


@pytest.fixture(scope="module")
def section():
    """A coarse Fig. 11 section (24 x 37 states, omega1 = 0 exactly among them: a zero of the initial
    state is the first crossing if it is transversal) and rimroll's DOP853 answer at rtol 1e-11."""
    b, w = np.meshgrid(np.linspace(0.8, 1.8, 24), np.linspace(-20.0, 20.0, 37), indexing="ij")
    x = np.stack([b, w, np.full_like(b, 35.0), np.full_like(b, 10.0)], -1).reshape(-1, 4)
    return x, solver.simulate(x, ROLLING, t_max=20.0, rtol=1e-11, atol=1e-13, method="dop853")


def test_outcomes_and_times_agree_with_rimroll_on_a_section(section):
    x, ref = section
    res = heyoka_rolling.classify(x, heyoka_rolling.Integrator(ROLLING, 1e-10), 20.0)
    np.testing.assert_array_equal(res["outcome"], ref["outcome"])
    assert set(np.unique(ref["outcome"])) >= {0, 1, 2}  # falls in and out, periodic orbits
    np.testing.assert_allclose(res["t_end"], ref["t_end"], rtol=0, atol=1e-7)
    per = ref["outcome"] == 2
    np.testing.assert_allclose(res["half_period"][per], ref["half_period"][per], rtol=0, atol=1e-7)
    assert np.isnan(res["half_period"][~per]).all()
    for name in ("beta", "omega1", "omega2", "omega3"):
        np.testing.assert_allclose(res[f"{name}_end"], ref[f"{name}_end"], rtol=0, atol=1e-5)
    drift = heyoka_rolling.energy_drift(x, res, ROLLING)
    assert drift.max() < 1e-9 and (drift[ref["t_end"] == 0] == 0).all()


def test_forked_workers_give_the_answer_of_one_process(section):
    x, _ = section
    integrator = heyoka_rolling.Integrator(ROLLING, 1e-8, batch=4)
    one = heyoka_rolling.classify(x, integrator, 20.0)
    with heyoka_rolling.Workers(x, [integrator], n=2) as workers:
        two = heyoka_rolling.classify(x, integrator, 20.0, workers)
        with pytest.raises(ValueError, match="other states"):
            heyoka_rolling.classify(x.copy(), integrator, 20.0, workers)
    np.testing.assert_array_equal(one["outcome"], two["outcome"])
    np.testing.assert_allclose(one["t_end"], two["t_end"], rtol=0, atol=1e-9)
    assert two["integrated"] == one["integrated"] > 0 and two["worker_cpu_s"] > 0 == one["worker_cpu_s"]
