"""The grazing gate of ``solver.engine.events.trough_possible``: a step skips the search for the
minimum of F2 only when the Hermite cubic of the event function, minus its interpolation error
bound, stays above zero. Driven on the oscillator test system (x = cos(t + t0))."""

import math

import numpy as np
import pytest

from rimroll.solver.engine import events, stepper
from rimroll.solver.engine.tableaus import TABLEAUS
from tests.helpers.oscillator import exact, pad, values
from tests.helpers.oscillator import one_step as _one_step


def _step(tab, t0, h):
    y = pad(exact(0.0, t0))
    y_new, K, Q = _one_step(stepper, tab, y, h)
    g0, r0 = values(y)
    g1, r1 = values(y_new, K[tab.n_stages])
    return y, y_new, Q, g0, r0, g1, r1


def _third(g0, r0, g1, r1, h):
    """Third derivative of the Hermite cubic of event 0 on a step (as the gate computes it)."""
    return events.trough_possible(g0[0], r0[0], g1[0], r1[0], h, h, np.nan, 0.0, 1e-8)[3]


def _gate(tab, t0, h, h_prev, rtol=1e-8, shift=0.0):
    """The gate on [t0, t0 + h] after a previous step [t0 - h_prev, t0]; event 0 is x + shift."""
    _, _, _, g0p, r0p, g1p, r1p = _step(tab, t0 - h_prev, h_prev)
    g0p[0] += shift
    g1p[0] += shift
    third_prev = _third(g0p, r0p, g1p, r1p, h_prev)
    y, y_new, Q, g0, r0, g1, r1 = _step(tab, t0, h)
    g0[0] += shift
    g1[0] += shift
    search, lo, th, _ = events.trough_possible(g0[0], r0[0], g1[0], r1[0], h, h_prev, third_prev, 0.0, rtol)
    return search, lo, th, (y, y_new, Q, g0, g1)


def test_first_step_of_a_phase_is_gated_by_the_remainder_measured_at_its_midpoint():
    """No previous step: the bound is GATE_SAFETY |g - H| at the midpoint of the dense output."""
    tab = TABLEAUS["dp5"]
    y, y_new, Q, g0, r0, g1, r1 = _step(tab, math.pi - 0.03, 0.05)
    out = np.zeros(7)
    stepper.dense_eval(0.5, y, 0.05, Q, 3, tab.n_poly, out)
    mid_err = abs(out[0] - events.hermite_at(g0[0], r0[0], g1[0], r1[0], 0.05, 0.5))
    assert 0 < mid_err < 0.05**4 / 384 * 1.01  # the remainder at the midpoint, within its bound
    for shift, want in ((1.0 + 1e-4, False), (1.0 - 1e-6, True)):  # trough at 1e-4; a dip to -1e-6
        a, b = g0[0] + shift, g1[0] + shift
        assert events.trough_possible(a, r0[0], b, r1[0], 0.05, 0.05, np.nan, mid_err, 1e-8)[0] == want


def test_a_step_far_from_zero_is_not_searched_and_a_near_trough_is():
    tab = TABLEAUS["dp5"]
    search, lo, _, _ = _gate(tab, 0.2, 0.05, 0.05)  # x ~ 0.98: far from 0
    assert not search and lo > 0.9
    # x = cos t + 1 + 1e-4 has its trough (1e-4) at t = pi, inside [pi - 0.03, pi + 0.02]
    search, lo, th, _ = _gate(tab, math.pi - 0.03, 0.05, 0.05, shift=1.0 + 1e-4)
    assert not search  # the bound (~h^5 / 384 << 1e-4) clears it
    # H is within its remainder bound h^4 max|x| / 384 of the true trough (x = cos)
    assert abs(lo - 1e-4) <= 0.05**4 / 384 * 1.01 and abs(th - 0.6) < 1e-3
    search, _, _, _ = _gate(tab, math.pi - 0.03, 0.05, 0.05, shift=1.0 - 1e-6)  # dips to -1e-6
    assert search


@pytest.mark.parametrize("name", sorted(TABLEAUS))
def test_every_dip_of_the_dense_output_is_gated_in(name):
    """Over many pairs of consecutive steps of many sizes and shifts, whenever the dense output of
    event 0 reaches <= 0 inside a step, the gate asks for the search."""
    tab = TABLEAUS[name]
    rng = np.random.default_rng(1)
    n_dips = 0
    for _ in range(3000):
        h = 10.0 ** rng.uniform(-3.0, -0.3)
        t0 = math.pi - rng.uniform(0.0, 1.0) * h  # the trough of x + shift at t = pi lies in the step
        h_prev = h * rng.uniform(0.5, 2.0)
        shift = 1.0 - 10.0 ** rng.uniform(-10.0, -1.0) * rng.choice([-1.0, 1.0])
        search, _, _, (y, _, Q, g0, g1) = _gate(tab, t0, h, h_prev, shift=shift)
        if not (g0[0] > 0 and g1[0] > 0):
            continue
        out = np.zeros(7)
        xs = []
        for th in np.linspace(0.0, 1.0, 401):
            stepper.dense_eval(th, y, h, Q, 3, tab.n_poly, out)
            xs.append(out[0] + shift)
        if min(xs) <= 0.0:
            n_dips += 1
            assert search, (t0, h, shift)
    assert n_dips > 200
