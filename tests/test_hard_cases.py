"""Hard numerical cases of the outcome engine (issue 6): singular steady motions, separatrix and
deadlock boundaries, tangential omega1 crossings, slip/roll switching on the friction cone,
large spin, long dissipative runs and the most unstable monodromy of Fig. 9.

Each case bounds the work (t_max, max_steps) and asserts the behaviour that is correct, not
merely what the engine does today (two of them first failed and led to engine fixes: the
transversality of omega1 zeros, and grazing falls hidden between dense-output samples).
"""

from __future__ import annotations

import numpy as np
import pytest

from rimroll import solver
from rimroll.solver.analysis import boundaries, floquet, steady
from rimroll.solver.engine import outcomes

P = solver.Params()  # Table 1, mu = 1
ROLL = P.replace(mu=float("inf"))
WEIGHT = P.m * P.g  # [N]
FLOAT_FIELDS = ("t_end", "f2_min", "revolutions", "slip_time", "energy_drift",
                "beta_end", "omega1_end", "omega2_end", "omega3_end")


def sim(states, p, **kw):
    kw.setdefault("workers", 1)
    return solver.simulate(np.atleast_2d(np.asarray(states, float)), p, **kw)


def assert_finite(r):
    for name in FLOAT_FIELDS:
        assert np.all(np.isfinite(r[name])), (name, r[name])
    periodic = r["outcome"] == outcomes.PERIODIC_ROLLING
    assert np.all(np.isfinite(r["half_period"][periodic]))
    assert np.all(np.isnan(r["half_period"][~periodic]))


def energy(beta, w1, w2, w3, p=P):
    """Mechanical energy (60) with the potential m g rho sin(beta) [J]."""
    r2 = p.r**2
    return (0.5 * p.m * p.j * r2 * w2**2 + 0.5 * p.m * (1 + p.j) * r2 * (w1**2 + w3**2)
            + p.m * p.g * p.rho * np.sin(beta))


# ------------------------------------------------------------------ singular steady motions
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


# ------------------------------------------------------------------ separatrix boundary
@pytest.fixture(scope="module")
def separatrix():
    """omega1* of the separatrix boundary of Fig. 11's periodic region at beta = 1.0601
    (rolling only), bracketed by bisection to ~1e-14 1/s."""
    ref = boundaries.refine([1.0601, 2.773, 35.0, 10.0], [1.0601, 2.975, 35.0, 10.0], ROLL, n_bisect=45)
    assert ref["type"] == boundaries.SEPARATRIX
    return ref["periodic"][1], ref["other"][1]


def test_next_to_a_separatrix_runs_end_in_bounded_work(separatrix):
    """Approaching the separatrix the half period grows like -ln(distance)/lambda (a saddle's
    homoclinic orbit); the runs end (periodic inside, a fall outside) without crawling."""
    w_in, w_out = separatrix
    d = np.array([1e-4, 1e-7, 1e-10, 1e-13])
    inside = np.stack([np.full(4, 1.0601), w_in - d, np.full(4, 35.0), np.full(4, 10.0)], -1)
    outside = inside.copy()
    outside[:, 1] = w_out + d
    r_in = sim(inside, ROLL, t_max=20.0, max_steps=20_000)
    r_out = sim(outside, ROLL, t_max=20.0, max_steps=20_000)
    for r in (r_in, r_out):
        assert (r["status"] == outcomes.OK).all()
        assert_finite(r)
        assert (r["n_steps"] < 1000).all(), r["n_steps"]  # ~100-200 steps; a crawl would be >> 1e3
    assert (r_in["outcome"] == outcomes.PERIODIC_ROLLING).all()
    assert np.isin(r_out["outcome"], (outcomes.FALL_IN, outcomes.FALL_OUT)).all()
    hp = r_in["half_period"]
    steps = np.diff(hp)  # one step per 1e3 in distance
    assert (steps > 0).all()
    assert np.ptp(steps) < 0.1 * steps.mean()  # logarithmic growth: equal increments per decade
    assert (r_in["f2_min"] > 0.5 * WEIGHT).all()  # F2_min does not go to 0: separatrix, not deadlock


# ------------------------------------------------------------------ deadlock boundary
@pytest.fixture(scope="module")
def deadlock_beta():
    """beta* of the deadlock boundary on top of Fig. 13's upper periodic region (omega1 = 0.05,
    rolling only): bisection with dp5 at rtol 1e-12 to ~1e-14 rad."""
    ref = boundaries.refine([1.613, 0.05, 105.0, 10.0], [1.633, 0.05, 105.0, 10.0], ROLL, n_bisect=45,
                            rtol=1e-12, atol=1e-14)
    assert ref["type"] == boundaries.DEADLOCK
    return 0.5 * (ref["periodic"][0] + ref["other"][0])


DEADLOCK_DISTANCES = (1e-5, 1e-4, 1e-3)  # [rad] >> every tolerance below


def _deadlock_outcomes(beta_star, method):
    states = [[beta_star + s * d, 0.05, 105.0, 10.0] for d in DEADLOCK_DISTANCES for s in (-1, 1)]
    out = {}
    for rtol in (1e-8, 1e-10, 1e-12):
        r = sim(states, ROLL, t_max=20.0, rtol=rtol, atol=rtol * 1e-2, method=method, max_steps=200_000)
        assert (r["status"] == outcomes.OK).all()
        assert_finite(r)
        out[rtol] = r
    return out


def _check_deadlock(out):
    expected = np.tile([outcomes.PERIODIC_ROLLING, outcomes.FALL_OUT], len(DEADLOCK_DISTANCES))
    for rtol, r in out.items():
        periodic = r["outcome"] == outcomes.PERIODIC_ROLLING
        assert (r["f2_min"][periodic] >= 0).all(), (rtol, r["f2_min"])  # periodic needs F2 > 0 throughout
        assert (r["outcome"] == expected).all(), (rtol, r["outcome"], r["f2_min"])


def test_grazing_fall_at_a_deadlock_is_found_consistently_dp5(deadlock_beta):
    _check_deadlock(_deadlock_outcomes(deadlock_beta, "dp5"))


def test_grazing_fall_at_a_deadlock_is_found_consistently_dop853(deadlock_beta):
    _check_deadlock(_deadlock_outcomes(deadlock_beta, "dop853"))


# ------------------------------------------------------------------ tangential omega1 crossings
def test_nearly_tangential_omega1_crossings_give_a_continuous_half_period():
    """Small orbits round Fig. 11's stable steady motion: omega1 starts at 0 (a crossing at t = 0),
    or at 1e-12..1e-6 (a crossing almost at once); the half period must not jump, and must be the
    linearised one pi / sqrt(-h) of (54) for small amplitude."""
    from rimroll.workflows.outcome_grids import steady_beta0

    b0 = steady_beta0(35.0, 10.0, ROLL, 0.8, 1.8)
    w1 = np.array([0.0, 1e-12, -1e-12, 1e-9, -1e-9, 1e-6, -1e-6])
    states = np.stack([np.full_like(w1, b0 + 1e-4), w1, np.full_like(w1, 35.0), np.full_like(w1, 10.0)], -1)
    r = sim(states, ROLL, t_max=20.0, rtol=1e-10, atol=1e-12)
    assert (r["status"] == outcomes.OK).all()
    assert (r["outcome"] == outcomes.PERIODIC_ROLLING).all(), r["outcome"]
    hp = r["half_period"]
    assert np.ptp(hp) < 1e-6 * hp.mean(), hp
    h = float(steady.stability(b0, 10.0, ROLL))
    assert h < 0
    assert hp.mean() == pytest.approx(np.pi / np.sqrt(-h), rel=1e-3)


# ------------------------------------------------------------------ switching on the cone (39)
@pytest.mark.parametrize("factor", [1 - 1e-9, 1.0, 1 + 1e-9])
def test_slip_roll_switching_on_the_friction_cone_does_not_hang(factor):
    """A steady motion whose required friction (56) equals mu to 1e-9, nudged: at most a bounded
    number of switches, status ok or too_many_switches, no NaN, within the step budget."""
    b0, w30 = 1.0, 10.0
    mu = float(steady.required_friction(b0, w30, P)) * factor
    p = P.replace(mu=mu)
    x = steady.steady_state(b0, w30, p)
    states = np.array([x, x + [0, 1e-6, 0, 0], x + [1e-6, 0, 0, 0]])
    r = sim(states, p, t_max=5.0, max_steps=200_000, max_switches=2000)
    assert np.isin(r["status"], (outcomes.OK, outcomes.TOO_MANY_SWITCHES)).all(), r["status"]
    assert_finite(r)
    assert (r["slip_phases"] <= 2000).all()


def test_chattering_state_of_the_fig12_slipping_scene_ends():
    """States of Fig. 12's slipping scene that slip again and again (~70 slip phases in 20 s)."""
    states = [[1.1672, 0.05, 65.0, 10.0], [1.1712, -0.5, 65.0, 10.0]]
    r = sim(states, P, t_max=20.0, max_steps=500_000, max_switches=10_000)
    assert np.isin(r["status"], (outcomes.OK, outcomes.TOO_MANY_SWITCHES)).all()
    assert_finite(r)
    assert (r["n_steps"] < 500_000).all()


# ------------------------------------------------------------------ large spin
@pytest.mark.parametrize("mu", [float("inf"), 1.0])
def test_very_large_omega2(mu):
    """omega2 = 1000 1/s (stiff-ish fast rotation): no NaN, within budget, and the conservative
    rolling energy drift stays at the tolerance level."""
    p = P.replace(mu=mu)
    w1 = np.array([0.0, 1.0, 5.0, -5.0])
    states = np.stack([np.full(4, 1.0), w1, np.full(4, 1000.0), np.full(4, 10.0)], -1)
    r = sim(states, p, t_max=2.0, max_steps=500_000)
    assert (r["status"] == outcomes.OK).all(), r["status"]
    assert_finite(r)
    rolled = r["slip_phases"] == 0
    assert (r["energy_drift"][rolled] < 1e-6).all(), r["energy_drift"]


# ------------------------------------------------------------------ long dissipative runs
@pytest.mark.parametrize("k", [{"k_r": 0.02}, {"k_d": 0.02}])
def test_long_dissipative_run_loses_energy_monotonically(k):
    """t_max = 600 s with rolling or drilling resistance from Fig. 11's stable steady motion
    (rolling only; k = 0.02 1/s makes it fall after ~10-20 s): the energy at t_end never
    increases with t_max, ends below E0, and the 600 s run ends by the rules (status ok)."""
    from rimroll.workflows.outcome_grids import steady_beta0

    p = ROLL.replace(**k)
    b0 = steady_beta0(35.0, 10.0, p, 0.8, 1.8)
    x0 = np.array([b0, 0.1, 35.0, 10.0])
    t_max = np.array([2.5, 5.0, 7.5, 600.0])
    energies, t_end = [], []
    for t in t_max:
        r = sim(x0, p, t_max=float(t), max_steps=2_000_000)
        assert r["status"][0] == outcomes.OK
        assert_finite(r)
        energies.append(energy(r["beta_end"][0], r["omega1_end"][0], r["omega2_end"][0], r["omega3_end"][0], p))
        t_end.append(r["t_end"][0])
    e0 = energy(*x0, p)
    energies = np.array(energies)
    assert (np.diff(energies) <= 1e-9 * e0).all(), energies
    assert energies[-1] < e0 and energies[2] < energies[0] < e0
    assert t_end[:3] == pytest.approx(t_max[:3])  # still on the rim at the short t_max
    assert 7.5 < t_end[3] <= 600.0


# ------------------------------------------------------------------ monodromy of Fig. 9
def test_monodromy_of_the_most_unstable_ball_on_the_fig9_range():
    """max |tr M| over Fig. 9's default 200 x 200 grid; there det M = 1 and mu1 mu2 = 1."""
    n = 200
    x_max = 1.0 - P.a / P.R
    x = (np.arange(n) + 0.5) / n * x_max
    j = (np.arange(n) + 1.0) / n * (2.0 / 3.0)
    X, J = np.meshgrid(x, j, indexing="ij")
    tr = floquet.trace(X, J)
    assert np.all(np.isfinite(tr))
    k = np.unravel_index(np.argmax(np.abs(tr)), tr.shape)
    xs, js = float(X[k]), float(J[k])
    M = floquet.monodromy(xs, js)
    assert abs(np.trace(M) - tr[k]) <= 1e-9 * abs(tr[k])
    assert abs(np.linalg.det(M) - 1.0) <= 1e-9 * np.abs(M).max() ** 2
    mu = floquet.multipliers(xs, js)
    assert abs(mu[0] * mu[1] - 1.0) < 1e-9
    assert abs(mu[1]) > 1.0 > abs(mu[0])  # unstable (region U)
    eig = np.sort(np.abs(np.linalg.eigvals(M)))
    assert eig[1] == pytest.approx(abs(mu[1]), rel=1e-9)
