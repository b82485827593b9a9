"""The rules of the outcome engine (docs/outcome-engine.md): steady motions, the tolerance range,
the large-mu limit, the cost against rtol, and one definition of each rule across implementations."""

from __future__ import annotations

import numpy as np
import pytest

from rimroll.solver import Params, simulate
from rimroll.solver.analysis import solution_types, steady
from rimroll.solver.analysis.scipy_reference import reference_one
from rimroll.solver.engine import outcomes, rules
from tests.helpers.bounded_runs import P, assert_finite, sim

INF = float("inf")
ROLL = Params(mu=INF)

# steady motions (47) over a grid of (beta0, omega30): stable (h < 0) and unstable (h > 0)
GRID = [(b, w) for b in (-0.3, 0.1, 0.8, 1.2, 1.5) for w in (-25.0, -10.0, 10.0, 25.0)]


def _steady_states(p, seed=0):
    """Exact steady states of GRID that stay on the rim, the top equilibrium (46), and copies of
    each moved by up to 1e-9 (relative) in every component."""
    x = steady.steady_state(np.array([g[0] for g in GRID]), np.array([g[1] for g in GRID]), p)
    keep = steady.stays_on_rim(x[:, 0], x[:, 3], p)
    x = np.vstack([x[keep], [[np.pi / 2, 0.0, 0.0, 0.0], [np.pi / 2, 0.0, 30.0, 0.0]]])
    rng = np.random.default_rng(seed)
    near = x * (1.0 + 1e-9 * rng.uniform(-1, 1, x.shape)) + 1e-9 * rng.uniform(-1, 1, x.shape)
    return np.vstack([x, near])


def test_the_grid_holds_stable_and_unstable_steady_motions():
    h = steady.stability(np.array([g[0] for g in GRID]), np.array([g[1] for g in GRID]), ROLL)
    assert (h < 0).sum() >= 3 and (h > 0).sum() >= 3


@pytest.mark.parametrize("method", ["dp5", "dop853"])
def test_steady_motions_are_the_same_outcome_for_every_t_max_rtol_and_method(method):
    x = _steady_states(ROLL)
    seen = []
    for t_max in (1.0, 5.0, 20.0, 60.0):
        for rtol in (1e-6, 1e-8, 1e-12):
            r = simulate(x, ROLL, t_max=t_max, rtol=rtol, atol=rtol * 1e-2, method=method)
            assert np.all(r["status"] == 0)
            seen.append(r["outcome"])
            assert np.all(r["outcome"] == outcomes.STEADY_MOTION)
            assert np.all(r["t_end"] == 0.0) and np.all(np.isnan(r["half_period"]))
            h = steady.stability(x[:, 0], x[:, 3], ROLL)
            np.testing.assert_allclose(r["steady_h"], h, rtol=1e-6)
    assert all(np.array_equal(s, seen[0]) for s in seen)


def test_steady_motion_with_finite_mu_inside_the_cone_and_dissipation():
    p = Params(mu=1.0)
    x = steady.steady_state(1.2, 10.0, p)
    assert steady.rolls_without_slipping(1.2, 10.0, p)
    assert simulate(x, p)["outcome"] == outcomes.STEADY_MOTION
    # rolling resistance makes omega3 decay: not a steady motion, the run goes on
    r = simulate(x, Params(mu=INF, k_r=0.02), t_max=2.0)
    assert r["outcome"] != outcomes.STEADY_MOTION and r["t_end"] > 0
    # ... but the ball at rest on top of the rim is an equilibrium of the dissipative equations too
    assert simulate([np.pi / 2, 0, 0, 0], Params(mu=INF, k_r=0.02))["outcome"] == outcomes.STEADY_MOTION


def test_a_small_real_oscillation_is_not_a_steady_motion():
    """A periodic orbit of relative amplitude 1e-4 around a stable steady motion is periodic."""
    x = steady.steady_state(1.2, 10.0, ROLL)
    assert steady.stability(1.2, 10.0, ROLL) < 0
    x[1] = 1e-4 * 10.0
    for rtol in (1e-6, 1e-8, 1e-12):
        assert simulate(x, ROLL, rtol=rtol, atol=rtol * 1e-2)["outcome"] == outcomes.PERIODIC_ROLLING


def test_one_definition_of_the_steady_and_transversal_rules():
    """The engine, the scipy reference and the solution types of Theorem 1 all use solver.engine.rules."""
    x = _steady_states(ROLL)[:6]
    for s in x:
        assert reference_one(s, ROLL, t_max=5.0)["outcome"] == outcomes.STEADY_MOTION
    kinds = solution_types.equilibrium_kind(x, ROLL, eq_tol=rules.STEADY_TOL)
    assert np.all(kinds >= 0)
    # the top equilibrium is the trivial one (46)
    top = solution_types.equilibrium_kind([[np.pi / 2, 0.0, 0.0, 0.0]], ROLL)
    assert top[0] == solution_types.TRIVIAL_EQUILIBRIUM


@pytest.mark.parametrize("rtol", [1.0, 10.0, 0.02, 1e-15, 0.0, float("nan")])
def test_tolerances_outside_the_meaningful_range_are_refused(rtol):
    with pytest.raises(ValueError, match="rtol"):
        simulate([[1.1, 2.0, 35.0, 10.0]], Params(), rtol=rtol)


def test_the_loosest_allowed_tolerance_still_gets_the_outcome_right():
    """At rtol = 1 the old engine said fall_in for this periodic state; 1e-2 is allowed and right."""
    x = [[1.1, 2.0, 35.0, 10.0]]
    truth = simulate(x, Params(), rtol=1e-10, atol=1e-12)
    assert truth["outcome"][0] == outcomes.PERIODIC_ROLLING
    loose = simulate(x, Params(), rtol=1e-2, atol=1e-4)
    assert loose["outcome"][0] == outcomes.PERIODIC_ROLLING
    assert loose["t_end"][0] == pytest.approx(truth["t_end"][0], rel=3e-2)


def test_on_rim_reason_reads_outcome_status_and_slips():
    o, ok = outcomes.ON_RIM_AT_T_MAX, outcomes.OK
    reason = outcomes.on_rim_reason([o, o, o, o, outcomes.FALL_OUT, o], [ok, ok, ok, outcomes.STIFF_SLIP, ok, ok],
                                    [0, 1, 5, 40, 3, 2])
    assert reason.tolist() == [outcomes.ROLLING_TRANSIENT, outcomes.ONE_SLIP, outcomes.SLIP_ROLL_CYCLING,
                               outcomes.STOPPED_EARLY, outcomes.NOT_ON_RIM, outcomes.SLIP_ROLL_CYCLING]


def _slipping_sample(n=40, seed=3):
    rng = np.random.default_rng(seed)
    x = np.stack([rng.uniform(0.8, 1.8, n), rng.uniform(-20, 20, n), np.full(n, 35.0), np.full(n, 10.0)], -1)
    return x


def test_work_falls_as_the_tolerance_loosens_in_the_slipping_scene():
    """Attempted steps (the engine's work) never grow as rtol loosens: 1e-10 ... 1e-3."""
    x = _slipping_sample()
    p = Params(mu=1.0)
    work = []
    for rtol in (1e-10, 1e-8, 1e-6, 1e-4, 1e-3):
        r = simulate(x, p, t_max=5.0, rtol=rtol, atol=rtol * 1e-2)
        assert (r["slip_phases"] > 0).sum() >= 10
        work.append(int(r["n_steps"].sum()))
    assert all(b <= a for a, b in zip(work, work[1:])), work


SINGULAR = [  # (beta0 [rad], omega30 [1/s]): omega20 of (48) is ~1e4 1/s at each
    (np.pi / 2 - 1e-3, 10.0), (np.pi / 2 - 1e-3, -10.0), (-np.pi / 2 + 1e-3, 10.0),
    (1.0, 1e-2), (1.0, -1e-2), (0.5, 1e-2),
]


@pytest.mark.parametrize("mu", [float("inf"), 1.0])
@pytest.mark.parametrize("beta0,omega30", SINGULAR)
def test_steady_motion_near_singular_lines_stays_or_falls_at_once(beta0, omega30, mu):
    """A steady motion (47) next to beta0 = +-pi/2 or omega30 = 0 (|omega20| ~ 1e4 1/s): if it
    stays on the rim (F2 > 0 and, with finite mu, inside the friction cone) it is reported as
    ``steady_motion`` at t = 0 with its h of (54), else it must leave at once; never NaN,
    status ok."""
    p = P.replace(mu=mu)
    x = steady.steady_state(beta0, omega30, p)
    assert abs(x[2]) > 5e3
    r = sim(x, p, t_max=1.0, max_steps=100_000)
    assert r["status"][0] == outcomes.OK
    assert_finite(r)
    on_rim = bool(steady.stays_on_rim(beta0, omega30, p)) and (
        np.isinf(mu) or bool(steady.rolls_without_slipping(beta0, omega30, p, mu)))
    if on_rim:
        assert r["outcome"][0] == outcomes.STEADY_MOTION
        end = np.array([r[k][0] for k in ("beta_end", "omega1_end", "omega2_end", "omega3_end")])
        np.testing.assert_array_equal(end, x)
        assert r["t_end"][0] == 0.0 and r["slip_phases"][0] == 0 and r["n_steps"][0] == 0
        assert r["steady_h"][0] == pytest.approx(float(steady.stability(beta0, omega30, p)), rel=1e-12)
    else:
        assert r["outcome"][0] in (outcomes.FALL_IN, outcomes.FALL_OUT)
        assert r["t_end"][0] < 0.2


def test_exact_steady_motion_is_a_steady_motion_not_a_periodic_orbit():
    x = steady.steady_state(np.pi / 2 - 1e-3, 10.0, ROLL)
    for t_max in (1.0, 5.0):
        r = sim(x, ROLL, t_max=t_max)
        assert r["outcome"][0] == outcomes.STEADY_MOTION and np.isnan(r["half_period"][0])


@pytest.mark.parametrize("method", ["dp5", "reduced"])
def test_nearly_tangential_omega1_crossings_give_a_continuous_half_period(method):
    """Small orbits round Fig. 11's stable steady motion: omega1 starts at 0 (a crossing at t = 0),
    or at 1e-12..1e-6 (a crossing almost at once); the half period must not jump, and must be the
    linearised one pi / sqrt(-h) of (54) for small amplitude."""
    from rimroll.workflows.outcome_grids import steady_beta0

    b0 = steady_beta0(35.0, 10.0, ROLL, 0.8, 1.8)
    w1 = np.array([0.0, 1e-12, -1e-12, 1e-9, -1e-9, 1e-6, -1e-6])
    states = np.stack([np.full_like(w1, b0 + 1e-4), w1, np.full_like(w1, 35.0), np.full_like(w1, 10.0)], -1)
    r = sim(states, ROLL, t_max=20.0, rtol=1e-10, atol=1e-12, method=method)
    assert (r["status"] == outcomes.OK).all()
    assert (r["outcome"] == outcomes.PERIODIC_ROLLING).all(), r["outcome"]
    hp = r["half_period"]
    assert np.ptp(hp) < 1e-6 * hp.mean(), hp
    h = float(steady.stability(b0, 10.0, ROLL))
    assert h < 0
    assert hp.mean() == pytest.approx(np.pi / np.sqrt(-h), rel=1e-3)
