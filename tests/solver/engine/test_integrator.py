"""The generic embedded RK stepper, its tableaus, dense output and event location.

Driven on the oscillator test system of ``tests/helpers/oscillator.py`` (x' = v, v' = -x, q' = x;
exact solution x = cos(t + t0) ...), handed to the very same compiled stepper and locator as
the physics systems.
"""

import math
from typing import NamedTuple

import numpy as np
import pytest

from rimroll.solver.engine import events, stepper
from rimroll.solver.engine.tableaus import TABLEAUS
from tests.helpers.oscillator import AUX, N_EVENTS, N, P, exact, pad, rhs, values
from tests.helpers.oscillator import events as osc_events
from tests.helpers.oscillator import one_step as _one_step

METHODS = sorted(TABLEAUS)


def one_step(tab, y, h):
    return _one_step(stepper, tab, y, h)


@pytest.mark.parametrize("name", METHODS)
def test_tableau_invariants(name):
    tab = TABLEAUS[name]
    s = tab.n_stages
    assert tab.B.sum() == pytest.approx(1.0, abs=1e-14)
    np.testing.assert_allclose(tab.A.sum(axis=1), tab.C, atol=1e-14)
    assert np.all(np.triu(tab.A) == 0.0)  # explicit
    np.testing.assert_array_equal(tab.A[s, :s], tab.B)  # FSAL row
    assert tab.C[s] == 1.0
    assert abs(tab.E[0].sum()) < 1e-14  # an error estimator annihilates constants
    # the dense output at theta = 1 is the step's own weights (and the FSAL/extra stages vanish)
    np.testing.assert_allclose(tab.P.sum(axis=1), np.r_[tab.B, np.zeros(tab.n_dense - s)], atol=1e-13)


@pytest.mark.parametrize("name,hs", [("dp5", (0.2, 0.1, 0.05)), ("dop853", (0.5, 0.35, 0.25))])
def test_convergence_order(name, hs):
    tab = TABLEAUS[name]
    errs = []
    T = 2.0
    for h in hs:
        y = pad(exact(0.0))
        for _ in range(int(round(T / h))):
            y, _, _ = one_step(tab, y, h)
        errs.append(np.abs(y[:3] - exact(T)).max())
    slope = np.polyfit(np.log(hs), np.log(errs), 1)[0]
    assert abs(slope - tab.order) < 0.6, (errs, slope)


@pytest.mark.parametrize("name", METHODS)
def test_error_estimate_bounds_true_error(name):
    tab = TABLEAUS[name]
    h = 0.3
    y = pad(exact(0.0))
    y_new, K, _ = one_step(tab, y, h)
    true = np.abs(y_new[:3] - exact(h))
    rtol, atol = 1e-12, 1e-14
    err = stepper.error_norm(K, tab.E, tab.err_mode, tab.n_stages, h, y, y_new, 3, rtol, np.full(7, atol))
    scale = atol + rtol * np.maximum(np.abs(y[:3]), np.abs(y_new[:3]))
    assert np.sqrt(np.mean((true / scale) ** 2)) < err


@pytest.mark.parametrize("name", METHODS)
def test_dense_output_reproduces_ends_and_interpolates(name):
    tab = TABLEAUS[name]
    h = 0.2
    y = pad(exact(0.0))
    y_new, _, Q = one_step(tab, y, h)
    out = np.zeros(7)
    stepper.dense_eval(0.0, y, h, Q, 3, tab.n_poly, out)
    np.testing.assert_array_equal(out[:3], y[:3])
    stepper.dense_eval(1.0, y, h, Q, 3, tab.n_poly, out)
    np.testing.assert_allclose(out[:3], y_new[:3], rtol=0, atol=1e-13)  # DOP853: rounding of its D table
    # interior: accurate to the interpolant's order (4 for dp5, 7 for dop853)
    bound = {"dp5": 1e-6, "dop853": 1e-10}[name]
    for theta in (0.25, 0.5, 0.8):
        stepper.dense_eval(theta, y, h, Q, 3, tab.n_poly, out)
        assert np.abs(out[:3] - exact(theta * h)).max() < bound


class EventTable(NamedTuple):
    """An event table as the locator reads it (a phase's ``system.Phase`` has these fields too)."""

    active: np.ndarray
    direction: np.ndarray
    track_min: np.ndarray


def scratch():
    return events.Scratch(np.zeros(7), np.zeros(7), *(np.zeros(N_EVENTS) for _ in range(4)))


def search_step(tab, y, h, t, sign, direction, active, track_min, search):
    """Step once with fixed h and search its dense output for events. Returns (y_new, Q, event, theta, mins)."""
    y_new, K, Q = one_step(tab, y, h)
    g0, _ = values(y)
    g1, gr1 = values(y_new, K[tab.n_stages])
    tracking = events.Tracking(sign, search, np.full(N_EVENTS, 0.5), np.full(N_EVENTS, np.inf))
    ev, theta = events.next_event(osc_events, EventTable(active, direction, track_min), tracking, 0.0, g0, g1, gr1,
                                  events.Dense(y, h, t, Q, N), P, AUX, scratch())
    return y_new, Q, ev, theta, tracking.mins


@pytest.mark.parametrize("name", METHODS)
def test_events_located_against_closed_form(name):
    """x = cos t: x - 1/2 crosses down at pi/3, x at pi/2, v = -sin t crosses up at pi."""
    tab = TABLEAUS[name]
    direction = np.array([-1, 1, -1])
    active = np.ones(3, dtype=np.bool_)
    no_min = np.zeros(3, dtype=np.bool_)
    y = pad(exact(0.0))
    g, _ = values(y)
    sign = np.zeros(3, dtype=np.int64)
    events.initial_signs(g, direction, sign)  # v = 0 at t = 0 counts as below (upward event)
    h = 0.01
    t = 0.0
    found = {}
    while t < 4.0 and len(found) < 3:
        y_new, Q, ev, theta, _ = search_step(tab, y, h, t, sign, direction, active, no_min, no_min)
        if ev >= 0:
            found[ev] = t + theta * h
            # the point returned lies on the far side of the crossing, within ~4 eps of it
            out = np.zeros(7)
            stepper.dense_eval(theta, y, h, Q, 3, tab.n_poly, out)
            gv, _ = values(out)
            assert gv[ev] * direction[ev] >= 0.0 and abs(gv[ev]) < 1e-13
            sign[ev] = -sign[ev]
            active[ev] = False  # one crossing of each is enough
            continue  # search the same step again for later events (the step is re-taken from y)
        y = y_new
        t += h
    tol = {"dp5": 1e-11, "dop853": 1e-13}[name]
    assert abs(found[2] - math.pi / 3) < tol
    assert abs(found[0] - math.pi / 2) < tol
    assert abs(found[1] - math.pi) < tol


@pytest.mark.parametrize("h,depth,tol", [(3.5, 1e-2, None), (0.3, 1e-4, 1e-8), (0.03, 1e-6, 1e-8)])
def test_grazing_dip_inside_one_step_is_decided_at_its_minimum(h, depth, tol):
    """x(t) = cos(t) + c over one step, with c chosen so that x is positive at both step ends
    and dips below zero only inside (the dip around t = pi is narrower than a tenth of the
    step for the last two cases): the minimum search finds it and the first zero is located.
    """
    tab = TABLEAUS["dop853"]
    # the minimum of cos (at t = pi) lies inside the step
    t_start = math.pi - 0.5 * h + 0.1 * h
    # x = cos(t) + (1 - depth) crosses zero where cos(t) = -(1 - depth)
    c = 1.0 - depth
    direction = np.array([-1, 1, -1])
    active = np.array([True, False, False])
    track = np.array([True, False, False])
    search = np.array([True, False, False])
    y = pad(exact(0.0, t_start))
    sign = np.ones(3, dtype=np.int64)
    # the event "x + c": positive at both ends, below zero in a window of width ~2 sqrt(2 depth)
    y_new, K, Q = one_step(tab, y, h)
    g0 = np.array([y[0] + c, y[1], y[0] - 0.5])
    g1 = np.array([y_new[0] + c, y_new[1], y_new[0] - 0.5])
    gr1 = np.array([K[tab.n_stages, 0], K[tab.n_stages, 1], K[tab.n_stages, 0]])
    assert g0[0] > 0 and g1[0] > 0
    width = 2 * math.sqrt(2 * depth)  # where x + c < 0
    assert width < 0.1 * h
    tracking = events.Tracking(sign, search, np.full(3, 0.5), np.full(N_EVENTS, np.inf))
    ev, theta = events.next_event(shifted_events, EventTable(active, direction, track), tracking, 0.0, g0, g1, gr1,
                                  events.Dense(y, h, t_start, Q, N), np.array([c]), AUX, scratch())
    assert ev == 0
    if tol is not None:  # where the dense output is accurate: the exact first zero
        assert abs(t_start + theta * h - math.acos(-c)) < tol


from numba import njit  # noqa: E402


@njit(cache=False)
def shifted_events(y, f, p, aux, g, gr):
    """The oscillator's events with event 0 shifted up by p[0]: x + p[0]."""
    g[0] = y[0] + p[0]
    gr[0] = f[0]
    g[1] = y[1]
    gr[1] = f[1]
    g[2] = y[0] - 0.5
    gr[2] = f[0]


def _attempt(tab, t, y, h, budget):
    K = np.zeros((tab.n_dense, 7))
    rhs(y, P, K, 0)
    f = K[0].copy()
    y_new, tmp = np.zeros(7), np.zeros(7)
    control = stepper.Control(N, N, 1e-8, np.full(7, 1e-10), t + 1.0)
    return stepper.attempt(rhs, tab.method, control, P, stepper.Arrays(y, f, K, y_new, tmp), t, h, False, budget)


@pytest.mark.parametrize("name", METHODS)
def test_step_attempt_reports_every_way_it_can_end(name):
    tab = TABLEAUS[name]
    y = pad(exact(0.0))
    code, h, h_next, attempts, last = _attempt(tab, 0.0, y, 2.0, 1000)
    assert code == stepper.ACCEPTED and attempts > 1 and h < 2.0 and h_next > 0  # 2 s is too long at 1e-8
    assert _attempt(tab, 0.0, y, 2.0, 1)[0] == stepper.BUDGET_SPENT
    assert _attempt(tab, 1e16, y, 1e-3, 1000)[0] == stepper.UNDERFLOW  # 1e-3 s is below 10 ulps of 1e16 s
    bad = y.copy()
    bad[0] = np.inf
    code, _, _, attempts, _ = _attempt(tab, 0.0, bad, 0.1, 1000)
    assert code == stepper.NON_FINITE and attempts == stepper.MAX_NONFINITE_RETRIES + 1
    code, h, _, _, last = _attempt(tab, 0.0, y, 10.0, 1000)  # a step never passes t_end
    assert code == stepper.ACCEPTED and h <= 1.0
