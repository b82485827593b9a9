"""No grazing fall missed: the engine against an independent reference that finds every interior
minimum of F2 (scipy DOP853 at rtol 1e-12 with a non-terminal dF2/dt = 0 event, F2 checked at
each located minimum: ``solver.analysis.scipy_reference``), on seeded states of the Fig. 11-13 sections, rolling
only and with slipping (mu = 1), at rtol 1e-6 and 1e-8.

Where the reference's outcome is a fall whose F2 minimum lies deeper than the engine's resolution
of F2 at its rtol, the engine must fall too, at the same time. The default run checks a 200-state
subset; ``-m slow`` checks 2,400 states.
"""

from __future__ import annotations

import numpy as np
import pytest

from rimroll.solver import Params, simulate
from rimroll.solver.analysis import boundaries
from rimroll.solver.analysis.scipy_reference import reference
from rimroll.solver.engine import outcomes
from tests.helpers.bounded_runs import ROLL, assert_finite, sim

T_MAX = 5.0
FALLS = (outcomes.FALL_IN, outcomes.FALL_OUT)


def section_states(n, seed):
    """n seeded states spread over the three outcome sections (omega2 = 35, 65, 105 1/s)."""
    rng = np.random.default_rng(seed)
    return np.stack([rng.uniform(0.8, 1.8, n), rng.uniform(-20.0, 20.0, n), rng.choice([35.0, 65.0, 105.0], n),
                     np.full(n, 10.0)], -1)


def compare(x, p, rtol):
    ref = reference(x, p, t_max=T_MAX, rtol=1e-12, atol=1e-13)
    ours = simulate(x, p, t_max=T_MAX, rtol=rtol, atol=rtol * 1e-2, method="dp5")  # the engine's grazing gate
    assert np.all(ours["status"] == 0)
    same = ours["outcome"] == ref["outcome"]
    ref_falls = np.isin(ref["outcome"], FALLS)
    our_falls = np.isin(ours["outcome"], FALLS)
    # a fall the engine misses, or a fall it reports later than the reference (a dip passed over)
    missed = ref_falls & ~(our_falls & np.isclose(ours["t_end"], ref["t_end"], rtol=1e-3, atol=0.0))
    return ref, ours, same, missed


def check(x, p, rtol):
    ref, ours, same, missed = compare(x, p, rtol)
    # at the engine's resolution a reference fall may be a separatrix or deadlock state that the
    # engine classifies otherwise; there must be none among the states the two classify alike,
    # and at most a handful (boundary states) overall
    assert missed.sum() <= max(1, int(0.005 * len(x))), (rtol, np.flatnonzero(missed), x[missed])
    agree = same & (ours["outcome"] != outcomes.ON_RIM_AT_T_MAX)
    tol = 1e-6 if rtol <= 1e-8 else 1e-4
    rel = np.abs(ours["t_end"][agree] - ref["t_end"][agree]) / np.maximum(ref["t_end"][agree], 1e-12)
    assert np.quantile(rel, 0.99) < tol, (rtol, np.sort(rel)[-5:])
    assert same.mean() > 0.99


@pytest.mark.parametrize("rtol", [1e-6, 1e-8])
@pytest.mark.parametrize("mu", [float("inf"), 1.0])
def test_no_grazing_fall_missed_subset(mu, rtol):
    check(section_states(100, seed=41), Params(mu=mu), rtol)


@pytest.mark.slow
@pytest.mark.parametrize("rtol", [1e-6, 1e-8])
@pytest.mark.parametrize("mu", [float("inf"), 1.0])
def test_no_grazing_fall_missed(mu, rtol):
    check(section_states(1200, seed=42), Params(mu=mu), rtol)


@pytest.mark.parametrize("depth", [1e-6, 1e-5, 1e-4, 1e-3])
def test_constructed_dips_narrower_than_a_tenth_of_the_step(depth):
    """States whose F2 minimum along the way is exactly -depth [N]: bisect omega1 between a
    state that stays on (minimum > 0) and one that falls at the dip, until the reference's
    minimum is -depth; the engine at rtol 1e-8 must fall at the dip. Up to 1e-4 N deep, F2 < 0
    for less than a tenth of the engine's mean step. The first zero of a dip of depth d is
    located to ~(F2 error) / sqrt(2 d F2''), so the tolerance on t_end widens as d shrinks."""
    p = Params(mu=float("inf"))

    x = _dip_of_depth(p, depth)
    ours = simulate(x, p, t_max=T_MAX, rtol=1e-8, atol=1e-10, method="dp5")  # the engine's steps, not the exact solver
    ref = reference(x, p, t_max=T_MAX, rtol=1e-12, atol=1e-13)
    assert ref["outcome"] in FALLS
    assert ours["outcome"] == ref["outcome"]
    assert ours["t_end"] == pytest.approx(float(ref["t_end"]), rel=1e-5 if depth < 1e-5 else 1e-6)
    if depth <= 1e-4:
        mean_step = ours["t_end"] / ours["n_steps"]
        assert _dip_width(p, x, depth) < 0.1 * mean_step


# A near-deadlock orbit of Fig. 12 (tests/solver/engine/test_simulate.py): F2 dips just below zero early on.
_X_DIP = np.array([0.92222377, 10.59047305, 65.0, 10.0])


def _f2_min_before_first_dip(p, x):
    """The reference's first interior minimum of F2 [N] along x (rolling, rtol 1e-12)."""
    from scipy.integrate import solve_ivp

    from rimroll.solver.physics import rolling

    a = p.as_array()

    def fun(t, y):
        return list(rolling.rolling_rhs.py_func(*y, a))

    def rate(t, y):
        b, w1, _, w3 = rolling.rolling_rhs.py_func(*y, a)
        return rolling.normal_force_rate.py_func(y[0], y[1], y[3], b, w1, w3, a)

    rate.direction = 1
    rate.terminal = 1
    sol = solve_ivp(fun, (0.0, 1.0), x, method="DOP853", rtol=1e-12, atol=1e-13, events=rate)
    y = sol.y_events[0][0]
    return float(rolling.normal_force.py_func(y[0], y[1], y[3], a)), float(sol.t_events[0][0]), sol


def _dip_of_depth(p, depth):
    """Bisect omega1 around _X_DIP until the first F2 minimum is -depth [N]."""
    lo, hi = _X_DIP[1] - 0.05, _X_DIP[1] + 0.05
    f_lo = _f2_min_before_first_dip(p, np.r_[_X_DIP[0], lo, _X_DIP[2:]])[0]
    f_hi = _f2_min_before_first_dip(p, np.r_[_X_DIP[0], hi, _X_DIP[2:]])[0]
    assert (f_lo + depth) * (f_hi + depth) < 0
    for _ in range(60):
        mid = 0.5 * (lo + hi)
        f = _f2_min_before_first_dip(p, np.r_[_X_DIP[0], mid, _X_DIP[2:]])[0]
        if (f + depth) * (f_lo + depth) > 0:
            lo, f_lo = mid, f
        else:
            hi = mid
        if abs(f + depth) < 1e-3 * depth:
            break
    return np.r_[_X_DIP[0], mid, _X_DIP[2:]]


def _dip_width(p, x, depth):
    """Time [s] during which F2 < 0 around the first minimum (reference)."""
    from scipy.optimize import brentq

    from rimroll.solver.physics import rolling

    a = p.as_array()
    fmin, tmin, _ = _f2_min_before_first_dip(p, x)
    from scipy.integrate import solve_ivp

    sol = solve_ivp(lambda t, y: list(rolling.rolling_rhs.py_func(*y, a)), (0.0, 2 * tmin + 0.01), x,
                    method="DOP853", rtol=1e-12, atol=1e-13, dense_output=True)

    def F2(t):
        y = sol.sol(t)
        return rolling.normal_force.py_func(y[0], y[1], y[3], a)

    span = 0.01
    left = brentq(F2, tmin - span, tmin)
    right = brentq(F2, tmin, tmin + span)
    return right - left


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


@pytest.fixture(scope="module")
def deadlock_beta():
    """beta* of the deadlock boundary on top of Fig. 13's upper periodic region (omega1 = 0.05,
    rolling only): bisection with dp5 at rtol 1e-12 to ~1e-14 rad."""
    ref = boundaries.refine([1.613, 0.05, 105.0, 10.0], [1.633, 0.05, 105.0, 10.0], ROLL, n_bisect=45,
                            rtol=1e-12, atol=1e-14)
    assert ref["type"] == boundaries.DEADLOCK
    return 0.5 * (ref["periodic"][0] + ref["other"][0])


def test_grazing_fall_at_a_deadlock_is_found_consistently_dp5(deadlock_beta):
    _check_deadlock(_deadlock_outcomes(deadlock_beta, "dp5"))


def test_grazing_fall_at_a_deadlock_is_found_consistently_dop853(deadlock_beta):
    _check_deadlock(_deadlock_outcomes(deadlock_beta, "dop853"))
