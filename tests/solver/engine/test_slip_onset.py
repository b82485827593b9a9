"""No slip onset missed: the friction-cone event (39) is located with a bound, as F2 is.

The friction margin mu F2 - |F_t| has an analytic rate (``rolling.friction_margin_rate``), so the
event locator bounds it between a step's ends and searches a dip below zero inside a step
(``solver.engine.events``). Checked here:

* the three Fig. 12 cells (mu = 1, omega2 = 65, omega3 = 10) that rimroll once reported as periodic
  rolling without a slip at dop853 (its 18 ms steps passed over the dip), and the documented cycling
  cell: the first slip onsets at dp5 and dop853, rtol 1e-6..1e-12, against the scipy reference
  (``solver.analysis.scipy_reference.integrate``, rtol 1e-12, the margin sampled 32 times a step);
* constructed near-cone states: random rolling states, and a mu just below the largest ratio
  |F_t| / F2 along the rolling trajectory (found on a dense sample of scipy's solution, rtol 1e-12),
  so that the margin dips below zero by a chosen depth for a fraction of a step; the engine must
  slip at the dip.
"""

from __future__ import annotations

import numpy as np
import pytest
from scipy.integrate import solve_ivp
from scipy.optimize import brentq, minimize_scalar

from rimroll.solver import Params, simulate
from rimroll.solver.analysis.scipy_reference import integrate
from rimroll.solver.engine import outcomes
from rimroll.solver.physics import rolling

HARD_ONSET_CELLS = np.array([[1.18912, 1.83844, 65.0, 10.0], [1.21004, 2.50696, 65.0, 10.0],
                        [1.21423, 2.61838, 65.0, 10.0], [1.21004, -2.50697, 65.0, 10.0]])
RTOLS = (1e-6, 1e-8, 1e-10, 1e-12)


def _reference_switch_times(x, p, n):
    """The reference's times [s] of the first n rolling/slipping switches of x (rtol 1e-12)."""
    return [integrate(x, p, t_max=20.0, rtol=1e-12, atol=1e-13, max_switches=k)["t_end"] for k in range(n)]


@pytest.fixture(scope="module")
def onset_reference():
    p = Params(mu=1.0)
    return np.array([_reference_switch_times(x, p, 4) for x in HARD_ONSET_CELLS])


@pytest.mark.parametrize("method", ["dp5", "dop853"])
@pytest.mark.parametrize("rtol", RTOLS)
def test_hard_onset_cells_first_slip_onset(onset_reference, method, rtol):
    """max_switches=0 stops a run at its first switch (status too_many_switches): the slip onset."""
    ours = simulate(HARD_ONSET_CELLS, Params(mu=1.0), t_max=20.0, rtol=rtol, atol=rtol * 1e-2, method=method,
                    max_switches=0)
    assert np.all(ours["status"] == outcomes.TOO_MANY_SWITCHES), ours["status"]
    tol = {1e-6: 2e-4, 1e-8: 1e-6}.get(rtol, 1e-7)
    np.testing.assert_allclose(ours["t_end"], onset_reference[:, 0], rtol=0.0, atol=tol)


@pytest.mark.parametrize("method", ["dp5", "dop853"])
@pytest.mark.parametrize("rtol", [1e-8, 1e-10, 1e-12])
def test_hard_onset_cells_first_switches(onset_reference, method, rtol):
    """Onset, return, second onset and second return, each at the reference's time."""
    for k in range(4):
        ours = simulate(HARD_ONSET_CELLS, Params(mu=1.0), t_max=20.0, rtol=rtol, atol=rtol * 1e-2, method=method,
                        max_switches=k)
        assert np.all(ours["status"] == outcomes.TOO_MANY_SWITCHES)
        np.testing.assert_allclose(ours["t_end"], onset_reference[:, k], rtol=0.0, atol=1e-4 if rtol > 1e-10 else 1e-6)


@pytest.mark.parametrize("method", ["dp5", "dop853"])
def test_hard_onset_cells_slip_and_roll_to_the_end(method):
    """The three cells once reported as periodic rolling: still on the rim at 20 s after many slips."""
    ours = simulate(HARD_ONSET_CELLS[:3], Params(mu=1.0), t_max=20.0, rtol=1e-10, atol=1e-12, method=method)
    assert np.all(ours["status"] == outcomes.OK)
    assert np.all(ours["outcome"] == outcomes.ON_RIM_AT_T_MAX)
    assert np.all(ours["slip_phases"] >= 10), ours["slip_phases"]


# ------------------------------------------------------------------ constructed near-cone states


class _Rolling:
    """The rolling trajectory of x by scipy DOP853 at rtol 1e-12 (no slipping: mu does not enter),
    with the ratio |F_t| / F2 of tangential to normal contact force on its dense output."""

    def __init__(self, x, t_max):
        self.a = Params(mu=float("inf")).as_array()
        a = self.a

        def fall(t, y):
            return rolling.normal_force.py_func(y[0], y[1], y[3], a)

        fall.terminal = True
        fall.direction = -1
        self.sol = solve_ivp(lambda t, y: list(rolling.rolling_rhs.py_func(*y, a)), (0.0, t_max), x,
                             method="DOP853", rtol=1e-12, atol=1e-13, dense_output=True, events=fall)
        self.t_end = float(self.sol.t[-1])

    def forces(self, t):
        y = self.sol.sol(t)
        F1, F2, F3 = rolling.contact_forces.py_func(y[0], y[1], y[2], y[3], self.a)
        return np.hypot(F1, F3), F2

    def ratio(self, t):
        ft, f2 = self.forces(t)
        return ft / f2

    def peak(self, n=20_000):
        """(t*, ratio(t*)): the largest |F_t| / F2 over [0, t_end - 0.05 s] where F2 > 1 N, from n
        samples refined by Brent; None where it lies at an end of that window (no dip there)."""
        t = np.linspace(0.0, self.t_end - 0.05, n)
        ft, f2 = self.forces(t)
        r = np.where(f2 > 1.0, ft / np.maximum(f2, 1.0), -np.inf)
        k = int(np.argmax(r))
        if k < 2 or k > n - 3 or not np.isfinite(r[k - 2]) or not np.isfinite(r[k + 2]):
            return None
        best = minimize_scalar(lambda s: -self.ratio(s), bounds=(t[k - 1], t[k + 1]), method="bounded",
                               options={"xatol": 1e-12})
        return float(best.x), float(-best.fun)

    def margin(self, mu, t):
        """The friction margin (39) mu F2 - |F_t| [N] at t for the friction coefficient mu."""
        ft, f2 = self.forces(t)
        return mu * f2 - ft

    def onset(self, mu, t_peak):
        """The first zero [s] of the margin before t_peak (dense sample, then Brent)."""
        t = np.linspace(0.0, t_peak, 20_000)
        below = np.flatnonzero(self.margin(mu, t) < 0)
        k = int(below[0]) if below.size else len(t) - 1
        return brentq(lambda s: float(self.margin(mu, s)), t[k - 1], t[k] if below.size else t_peak, xtol=1e-14)


def _near_cone_states(n, seed):
    """n random rolling states of the three outcome sections that stay on the rim for 0.3 s at least."""
    rng = np.random.default_rng(seed)
    out = []
    while len(out) < n:
        x = np.array([rng.uniform(0.9, 1.5), rng.uniform(-15.0, 15.0), rng.choice([35.0, 65.0, 105.0]), 10.0])
        roll = _Rolling(x, 1.5)
        if roll.t_end > 0.3 and roll.peak() is not None:
            out.append((x, roll))
    return out


def _check_dips(states, depths, method, rtol):
    for (x, roll), depth in zip(states, depths, strict=True):
        t_peak, mu_c = roll.peak()
        f2_peak = roll.forces(t_peak)[1]
        mu = mu_c - depth / f2_peak  # the margin's minimum is -depth [N], near t_peak
        t_on = roll.onset(mu, t_peak)
        ours = simulate(x, Params(mu=mu), t_max=1.5, rtol=rtol, atol=rtol * 1e-2, method=method, max_switches=0)
        where = f"x={x.tolist()}, mu={mu!r}, depth={depth:g} N, onset {t_on:.6f} s"
        assert ours["status"] == outcomes.TOO_MANY_SWITCHES, f"no slip: {where}; t_end {ours['t_end']}"
        # the first zero of a dip of depth d is located to ~ (margin error) / sqrt(2 d |margin''|)
        tol = 1e-3 if rtol > 1e-8 else (1e-5 if depth >= 1e-4 else 3e-4)
        assert abs(ours["t_end"] - t_on) < tol, where + f"; engine {ours['t_end']:.6f} s"


@pytest.mark.parametrize("method", ["dp5", "dop853"])
@pytest.mark.parametrize("rtol", [1e-6, 1e-8, 1e-10])
def test_near_cone_dips_found(method, rtol):
    """Random states, each with a mu that makes its margin dip 1e-5..1e-2 N below zero."""
    states = _near_cone_states(8, seed=22)
    depths = np.geomspace(1e-5, 1e-2, len(states))
    if rtol == 1e-6:
        depths = np.maximum(depths, 1e-4)  # shallower dips are within the margin's error at rtol 1e-6
    _check_dips(states, depths, method, rtol)


@pytest.mark.slow
@pytest.mark.parametrize("method", ["dp5", "dop853"])
@pytest.mark.parametrize("rtol", [1e-8, 1e-10, 1e-12])
def test_near_cone_dips_found_many(method, rtol):
    states = _near_cone_states(60, seed=23)
    depths = np.random.default_rng(24).choice(np.geomspace(1e-6, 1e-2, 9), len(states))
    _check_dips(states, depths, method, rtol)
