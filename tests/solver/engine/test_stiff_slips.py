"""Stiff slip phases: Rodas4 steps (``solver.engine.rosenbrock``) checked as a method, and the engine
that uses them checked against scipy's Radau (an independent implicit integrator, rtol 1e-10) on a
hard set (docs/outcome-engine.md, "Stiff slips"):

* a state with 1 slip, one with 7, and the Fig. 12 cycling cells through 30 slips (60 switches);
* the large-mu state [0.3288, 12, 35, 10] for mu = 1e3 .. 1e11: every row an answer, no stiff_slip;
* Fig. 12's cycling cell followed to t_max = 100 s within the default step budget (slow: all 72
  cycling cells of the panel).
"""

from __future__ import annotations

import numba
import numpy as np
import pytest

from rimroll.solver import Params, simulate
from rimroll.solver.analysis.scipy_reference import integrate, reference
from rimroll.solver.engine import outcomes, rosenbrock

SLIP = Params(mu=1.0)
ONE_SLIP = np.array([[0.8, -10.909090909090908, 65.0, 10.0], [0.8, 6.363636363636363, 65.0, 10.0]])
SEVEN_SLIPS = np.array([[1.1448275862068966, -0.9090909090909083, 65.0, 10.0]])
CYCLING = np.array([[1.2100418410041842, -2.5069637883008355, 65.0, 10.0], [1.18912, 1.83844, 65.0, 10.0]])
LARGE_MU_STATE = np.array([0.3288, 12.0, 35.0, 10.0])
RADAU = dict(rtol=1e-10, atol=1e-12, method="Radau")


# ------------------------------------------------------------------ the method on test equations


@numba.njit
def _linear_rhs(y, A, K, s):
    """y' = A y for the first n - 1 components; the last is the quadrature of the first."""
    n = A.shape[0]
    for i in range(n):
        acc = 0.0
        for c in range(n):
            acc += A[i, c] * y[c]
        K[s, i] = acc


@numba.njit
def _one_step(A, y0, h, out, Q):
    n = y0.shape[0]
    J = np.zeros((n, n))
    J[:, :] = A
    f = np.zeros((rosenbrock.N_ROWS, n))
    _linear_rhs(y0, A, f, 0)
    R = np.zeros((rosenbrock.N_ROWS, n))
    LU = np.zeros((n, n))
    piv = np.zeros(n, dtype=np.int64)
    tmp = np.zeros(n)
    ok = rosenbrock.rodas_step(_linear_rhs, y0, f[0], h, n, A, R, J, LU, piv, out, tmp)
    rosenbrock.dense_coefficients(R, y0, out, h, n, Q)
    return ok


def _decay(lam):
    """y1' = lam y1, y2' = -y1 + y2 / 2 (coupled), y3' = y1 (a quadrature: its column is zero)."""
    return np.array([[lam, 0.0, 0.0], [-1.0, 0.5, 0.0], [1.0, 0.0, 0.0]])


def _exact(lam, t):
    """The solution of :func:`_decay` from (1, 0, 0) at t."""
    y1 = np.exp(lam * t)
    y2 = -(np.exp(lam * t) - np.exp(0.5 * t)) / (lam - 0.5)
    return np.array([y1, y2, (np.exp(lam * t) - 1.0) / lam])


def test_rodas_local_error_is_of_order_five_and_its_dense_output_of_order_four():
    """One step of Rodas4 (order 4) has a local error O(h^5); its dense output (order 3) O(h^4)."""
    A, y0 = _decay(-1.0), np.array([1.0, 0.0, 0.0])
    errors, dense_errors = [], []
    for h in (0.04, 0.02, 0.01):
        out, Q = np.zeros(3), np.zeros((3, 4))
        assert _one_step(A, y0, h, out, Q)
        errors.append(np.max(np.abs(out - _exact(-1.0, h))))
        mid = y0 + h * (Q[:, 0] * 0.5 + Q[:, 1] * 0.25 + Q[:, 2] * 0.125 + Q[:, 3] * 0.0625)
        dense_errors.append(np.max(np.abs(mid - _exact(-1.0, 0.5 * h))))
    assert np.all(np.log2(np.array(errors[:-1]) / errors[1:]) > 4.6), errors
    assert np.all(np.log2(np.array(dense_errors[:-1]) / dense_errors[1:]) > 3.5), dense_errors


def test_rodas_is_l_stable():
    """Steps far longer than the decay time of y1 damp it as O(1/(h lam)) (L-stability: the stability
    function vanishes at infinity; an A-stable rule such as the trapezoidal one would keep |y1| ~ 1),
    and the coupled components stay at their exact values to a small fraction of their size."""
    h = 0.01
    for lam in (-1e6, -1e10):
        out, Q = np.zeros(3), np.zeros((3, 4))
        assert _one_step(_decay(lam), np.array([1.0, 0.0, 0.0]), h, out, Q)
        assert abs(out[0]) < 20.0 / abs(h * lam), (lam, out)
        np.testing.assert_allclose(out[1:], _exact(lam, h)[1:], rtol=0.0, atol=20.0 / abs(lam))


# ------------------------------------------------------------------ the engine against scipy Radau


@pytest.mark.parametrize("method", ["dp5", "dop853"])
def test_slipping_states_agree_with_radau(method):
    """A 1-slip and a 7-slip state: outcome, number of slips and t_end as scipy Radau at rtol 1e-10."""
    x = np.vstack([ONE_SLIP, SEVEN_SLIPS])
    ours = simulate(x, SLIP, t_max=20.0, rtol=1e-10, atol=1e-12, method=method)
    ref = reference(x, SLIP, t_max=20.0, **RADAU)
    assert np.all(ours["status"] == outcomes.OK)
    np.testing.assert_array_equal(ours["outcome"], ref["outcome"])
    np.testing.assert_array_equal(ours["slip_phases"], ref["slip_phases"])
    assert ours["slip_phases"].tolist() == [1, 1, 7]
    np.testing.assert_allclose(ours["t_end"], ref["t_end"], rtol=1e-8)


@pytest.fixture(scope="module")
def radau_switch_times():
    """Radau's times of the 20th and 60th switch (10 and 30 slips) of the cycling cells."""
    return {k: np.array([integrate(x, SLIP, t_max=20.0, max_switches=k, **RADAU)["t_end"] for x in CYCLING])
            for k in (20, 60)}


@pytest.mark.parametrize("method", ["dp5", "dop853"])
def test_cycling_cells_switch_as_radau_through_thirty_slips(radau_switch_times, method):
    """The 20th and the 60th rolling/slipping switch of two cycling cells at Radau's times (to 1e-6 s
    after ~13 s and 30 slips: the errors of the switches do not pile up)."""
    for k, times in radau_switch_times.items():
        ours = simulate(CYCLING, SLIP, t_max=20.0, rtol=1e-10, atol=1e-12, method=method, max_switches=k)
        assert np.all(ours["status"] == outcomes.TOO_MANY_SWITCHES)
        np.testing.assert_allclose(ours["t_end"], times, rtol=0.0, atol=1e-6)


def test_rosenbrock_and_explicit_slip_steps_agree_and_rosenbrock_costs_less():
    """switching={"slip_method": "explicit"} (the method's steps throughout the slip) gives the same switches; the
    Rosenbrock steps take fewer slip steps on each cycling cell, and at most a quarter in all (the
    first cell slips near delta, where the explicit steps sit at the stability limit)."""
    fast = simulate(CYCLING, SLIP, t_max=4.0, rtol=1e-10, atol=1e-12)
    slow = simulate(CYCLING, SLIP, t_max=4.0, rtol=1e-10, atol=1e-12, switching={"slip_method": "explicit"})
    np.testing.assert_array_equal(fast["slip_phases"], slow["slip_phases"])
    np.testing.assert_array_equal(fast["outcome"], slow["outcome"])
    assert np.all(fast["n_slip_steps"] < 0.5 * slow["n_slip_steps"]), (fast["n_slip_steps"], slow["n_slip_steps"])
    assert fast["n_slip_steps"].sum() < 0.25 * slow["n_slip_steps"].sum()


def test_slip_method_is_checked():
    with pytest.raises(ValueError, match="slip_method"):
        simulate(CYCLING, SLIP, switching={"slip_method": "radau"})


# ------------------------------------------------------------------ large mu: slipping precedes separation


@pytest.mark.parametrize("method", ["dp5", "dop853"])
def test_large_mu_rows_all_have_an_answer(method):
    """docs/outcome-engine.md, "Large mu": the state slips where mu F2 = |F_t|, rolls on, slips again
    and falls out at ~0.2375 s for every mu from 1e3 to 1e10 at rtol 1e-8 (to 1e11 at 1e-10), within
    a few 1e4 steps: the slip of mu = 1e8 .. 1e11, once beyond the step budget (status stiff_slip), is
    stiff in the normal force, not only in the slip angle, and the Rosenbrock steps take it. Rolling
    only, the state falls out at 0.00696 s."""
    for rtol, mus in ((1e-8, (1e3, 1e5, 1e7, 1e8, 1e9, 1e10)), (1e-10, (1e11,))):
        for mu in mus:
            r = simulate(LARGE_MU_STATE, Params(mu=mu), rtol=rtol, atol=rtol * 1e-2, method=method)
            assert r["status"] == outcomes.OK and r["outcome"] == outcomes.FALL_OUT, mu
            assert r["slip_phases"] == 2 and r["n_steps"] < 100_000, (mu, r["slip_phases"], r["n_steps"])
            assert r["t_end"] == pytest.approx(0.2375, abs=5e-4)
    rolling_only = simulate(LARGE_MU_STATE, Params(mu=float("inf")), method=method)
    assert rolling_only["outcome"] == outcomes.FALL_OUT and rolling_only["t_end"] == pytest.approx(0.006963, rel=1e-3)


@pytest.mark.parametrize("mu", [1e3, 1e5, 1e7, pytest.param(1e8, marks=pytest.mark.slow),
                                pytest.param(1e9, marks=pytest.mark.slow)])
def test_large_mu_agrees_with_radau(mu):
    """t_end as Radau's at rtol 1e-10: to 1e-8 relative for mu <= 1e5, 1e-7 for 1e7 and 1e8, 1e-5 for
    1e9 (the slip starts at F2 = |F_t| / mu ~ 3 / mu N, so the onset, and what follows, is resolved
    less well as mu grows: two scipy Radau runs with and without the analytic Jacobian differ by
    1e-8 at mu = 1e7)."""
    p = Params(mu=mu)
    ref = reference(LARGE_MU_STATE[None], p, t_max=20.0, **RADAU)
    for method in ("dp5", "dop853"):
        ours = simulate(LARGE_MU_STATE, p, rtol=1e-10, atol=1e-12, method=method)
        assert ours["outcome"] == ref["outcome"][0] and ours["slip_phases"] == ref["slip_phases"][0]
        assert ours["t_end"] == pytest.approx(ref["t_end"][0], rel=1e-5 if mu >= 1e9 else 1e-7 if mu >= 1e7 else 1e-8)


# ------------------------------------------------------------------ slip-roll cycling to 100 s


def test_the_cycling_cell_is_followed_to_100_s():
    """Fig. 12's cycling cell (docs/outcome-engine.md, "Slip-roll cycling"): its slips come at a
    steady rate (no Zeno accumulation) and cost tens of steps each, not ~6,000, so a run to 100 s
    ends within the default budget with an answer (status ok); without slipping the orbit is
    periodic and found at once."""
    early, late = simulate(CYCLING[0], SLIP, t_max=4.0), simulate(CYCLING[0], SLIP, t_max=8.0)
    first, second = int(early["slip_phases"]), int(late["slip_phases"] - early["slip_phases"])
    assert first >= 6 and abs(second - first) <= 2
    assert early["on_rim_reason"] == outcomes.SLIP_ROLL_CYCLING
    r = simulate(CYCLING[0], SLIP, t_max=100.0)
    assert r["status"] == outcomes.OK, r["status"]
    assert r["outcome"] == outcomes.FALL_OUT or r["on_rim_reason"] == outcomes.SLIP_ROLL_CYCLING
    assert r["slip_phases"] >= 30 and r["n_slip_steps"] < 100 * r["slip_phases"], (r["slip_phases"], r["n_slip_steps"])
    rolling = simulate(CYCLING[0], Params(mu=float("inf")), t_max=100.0, method="dp5")  # the integrator's steps
    assert rolling["outcome"] == outcomes.PERIODIC_ROLLING and rolling["n_steps"] < 1000


@pytest.mark.slow
def test_all_72_cycling_cells_of_fig12_are_followed_to_100_s():
    """The slipping panel of Fig. 12 (360 x 240, omega2 = 65, omega3 = 10 1/s, mu = 1): its 72 cells
    still cycling at 20 s all end by 100 s with status ok within the default budget, each fallen or
    still cycling (the reason recorded)."""
    beta, omega1 = np.meshgrid(np.linspace(0.8, 1.8, 240), np.linspace(-20.0, 20.0, 360), indexing="ij")
    x = np.stack([beta, omega1, np.full_like(beta, 65.0), np.full_like(beta, 10.0)], axis=-1).reshape(-1, 4)
    at20 = simulate(x, SLIP, t_max=20.0)
    cycling = x[at20["on_rim_reason"] == outcomes.SLIP_ROLL_CYCLING]
    assert len(cycling) == 72
    r = simulate(cycling, SLIP, t_max=100.0)
    assert np.all(r["status"] == outcomes.OK)
    fell = r["outcome"] <= outcomes.FALL_OUT
    assert np.all(fell | (r["on_rim_reason"] == outcomes.SLIP_ROLL_CYCLING))
    assert np.all(r["t_end"][fell] > 20.0) and np.all(r["n_steps"] < 1_000_000)
