"""The generic embedded RK stepper, its tableaus, dense output and event location.

Driven on the OSCILLATOR test phase of ``solver.system`` (x' = v, v' = -x, q' = x; exact
solution x = cos(t + t0) ...), so the very same compiled code as the physics runs is checked.
"""

import math

import numpy as np
import pytest

from solver import events, stepper
from solver.switching import default_tolerances
from solver.system import N_EVENTS, OSCILLATOR, event_values, rhs
from solver.tableaus import TABLEAUS

P = np.zeros(10)  # the oscillator ignores the parameters
SW = default_tolerances()
METHODS = sorted(TABLEAUS)


def exact(t, t0=0.0):
    """Oscillator state at t starting from (cos t0, -sin t0, sin t0) at t = 0."""
    return np.array([math.cos(t + t0), -math.sin(t + t0), math.sin(t + t0)])


def one_step(tab, y, h):
    n = 3
    f = np.zeros(7)
    rhs(OSCILLATOR, y, P, f)
    K = np.zeros((tab.n_dense, 7))
    y_new = np.zeros(7)
    tmp = np.zeros(7)
    stepper.rk_step(OSCILLATOR, 0.0, y, f, h, n, tab.A, tab.n_stages, K, y_new, tmp, P)
    Q = np.zeros((7, tab.n_poly))
    stepper.dense_prepare(OSCILLATOR, y, h, n, tab.A, tab.n_stages, tab.n_dense, tab.P, tab.n_poly, K, Q, tmp, P)
    return y_new, K, Q


def pad(v):
    out = np.zeros(7)
    out[: len(v)] = v
    return out


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
    err = stepper.error_norm(K, tab.E, tab.err_mode, tab.n_stages, h, y, y_new, 3, rtol, atol)
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


def scan_step(tab, y, h, t, sign, direction, active):
    """Step once with fixed h and scan the dense output for events. Returns (y_new, event, theta)."""
    y_new, _, Q = one_step(tab, y, h)
    g0 = np.zeros(N_EVENTS)
    event_values(OSCILLATOR, False, y, P, SW, g0)
    w = [np.zeros(7) for _ in range(2)]
    gs = [np.zeros(N_EVENTS) for _ in range(3)]
    ev, theta, _ = events.scan(OSCILLATOR, False, active, direction, sign, 0.0, g0, y, y_new, h, t, Q, 3,
                               tab.n_poly, P, SW, w[0], gs[0], gs[1], w[1], gs[2])
    return y_new, Q, ev, theta


@pytest.mark.parametrize("name", METHODS)
def test_events_located_against_closed_form(name):
    """x = cos t: x - 1/2 crosses down at pi/3, x at pi/2, v = -sin t crosses up at pi."""
    tab = TABLEAUS[name]
    direction = np.array([-1, 1, -1])
    active = np.ones(3, dtype=np.bool_)
    y = pad(exact(0.0))
    g = np.zeros(3)
    event_values(OSCILLATOR, False, y, P, SW, g)
    sign = np.zeros(3, dtype=np.int64)
    events.initial_signs(g, direction, sign)  # v = 0 at t = 0 counts as below (upward event)
    h = 0.01
    t = 0.0
    found = {}
    while t < 4.0 and len(found) < 3:
        y_new, Q, ev, theta = scan_step(tab, y, h, t, sign, direction, active)
        if ev >= 0:
            found[ev] = t + theta * h
            # the point returned lies on the far side of the crossing, within ~4 eps of it
            out = np.zeros(7)
            stepper.dense_eval(theta, y, h, Q, 3, tab.n_poly, out)
            gv = np.zeros(3)
            event_values(OSCILLATOR, False, out, P, SW, gv)
            assert gv[ev] * direction[ev] >= 0.0 and abs(gv[ev]) < 1e-13
            sign[ev] = -sign[ev]
            active[ev] = False  # one crossing of each is enough
            continue  # rescan the same step for later events (the step is re-taken from y)
        y = y_new
        t += h
    tol = {"dp5": 1e-11, "dop853": 1e-13}[name]
    assert abs(found[2] - math.pi / 3) < tol
    assert abs(found[0] - math.pi / 2) < tol
    assert abs(found[1] - math.pi) < tol


def test_grazing_dip_inside_one_step_is_found():
    """x = cos t over one step [1.4, 4.9]: positive at both ends, negative in between.

    A check of the signs at the step ends misses the downward crossing of x at pi/2; the samples
    on the dense output find it.
    """
    tab = TABLEAUS["dop853"]
    t0, h = 1.4, 3.5
    y = pad(exact(0.0, t0))
    direction = np.array([-1, 1, -1])
    active = np.array([True, False, False])
    g = np.zeros(3)
    event_values(OSCILLATOR, False, y, P, SW, g)
    sign = np.zeros(3, dtype=np.int64)
    events.initial_signs(g, direction, sign)
    y_new, Q, ev, theta = scan_step(tab, y, h, t0, sign, direction, active)
    assert y[0] > 0 and y_new[0] > 0  # a naive end-point check sees no sign change
    assert ev == 0
    assert abs(t0 + theta * h - math.pi / 2) < 0.05
