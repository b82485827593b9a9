"""The grazing gate of ``solver.events.may_cross``: steps skip the sampled event scan only when
no sign change is possible. Driven on the OSCILLATOR test phase (x = cos(t + t0))."""

import math

import numpy as np
import pytest

from solver import events, stepper
from solver.system import N_EVENTS, OSCILLATOR, event_rates, event_values, rhs
from solver.switching import default_tolerances
from solver.tableaus import TABLEAUS

P = np.zeros(10)
SW = default_tolerances()


def _ends(y, y_new, f, f_new):
    g0, r0, g1, r1 = (np.zeros(N_EVENTS) for _ in range(4))
    event_values(OSCILLATOR, False, y, P, SW, g0)
    event_rates(OSCILLATOR, False, y, f, P, SW, r0)
    event_values(OSCILLATOR, False, y_new, P, SW, g1)
    event_rates(OSCILLATOR, False, y_new, f_new, P, SW, r1)
    return g0, r0, g1, r1


def _step(tab, t0, h):
    y = np.zeros(7)
    y[:3] = (math.cos(t0), -math.sin(t0), math.sin(t0))
    f = np.zeros(7)
    rhs(OSCILLATOR, y, P, f)
    K = np.zeros((tab.n_dense, 7))
    y_new, tmp = np.zeros(7), np.zeros(7)
    stepper.rk_step(OSCILLATOR, 0.0, y, f, h, 3, tab.A, tab.n_stages, K, y_new, tmp, P)
    Q = np.zeros((7, tab.n_poly))
    stepper.dense_prepare(OSCILLATOR, y, h, 3, tab.A, tab.n_stages, tab.n_dense, tab.P, tab.n_poly, K, Q, tmp, P)
    return y, y_new, f, K[tab.n_stages].copy(), Q


def _signs(g):
    sign = np.zeros(N_EVENTS, dtype=np.int64)
    events.initial_signs(g, np.zeros(N_EVENTS, dtype=np.int64), sign)
    return sign


def test_the_constructed_dip_is_scanned():
    """x = cos t over [1.4, 4.9]: positive at both ends, negative inside (test_integrator's dip)."""
    y, y_new, f, f_new, _ = _step(TABLEAUS["dop853"], 1.4, 3.5)
    g0, r0, g1, r1 = _ends(y, y_new, f, f_new)
    active = np.array([True, False, False])
    assert g0[0] > 0 and g1[0] > 0
    assert events.may_cross(active, _signs(g0), g0, r0, g1, r1, 3.5, np.inf)


def test_a_step_far_from_every_zero_is_not_scanned():
    y, y_new, f, f_new, _ = _step(TABLEAUS["dp5"], 0.2, 0.05)  # x ~ 0.98, v ~ -0.2, x - 1/2 ~ 0.48
    g0, r0, g1, r1 = _ends(y, y_new, f, f_new)
    active = np.ones(3, dtype=np.bool_)
    assert not events.may_cross(active, _signs(g0), g0, r0, g1, r1, 0.05, -1.0)
    # ... but it is when it may hold a new running minimum of event 0 (F2 in the physics)
    y, y_new, f, f_new, _ = _step(TABLEAUS["dp5"], math.pi - 0.03, 0.05)  # x = cos t has its trough inside
    g0, r0, g1, r1 = _ends(y, y_new, f, f_new)
    g0[0] += 3.0  # keep event 0 positive: a trough at 2.0
    g1[0] += 3.0
    sign = _signs(g0)
    active = np.array([True, False, False])
    assert events.may_cross(active, sign, g0, r0, g1, r1, 0.05, np.inf)
    assert not events.may_cross(active, sign, g0, r0, g1, r1, 0.05, 1.5)


@pytest.mark.parametrize("name", sorted(TABLEAUS))
def test_every_sampled_sign_change_is_gated_in(name):
    """Over many steps of many sizes, whenever the dense output of x or v changes sign inside
    a step (or at its end), the gate asks for the scan."""
    tab = TABLEAUS[name]
    rng = np.random.default_rng(1)
    active = np.array([True, True, False])
    n_dips = 0
    n_changes = 0
    for _ in range(3000):
        t0 = rng.uniform(0.0, 2.0 * math.pi)
        h = 10.0 ** rng.uniform(-3.0, 0.75)  # up to 5.6: dips of width pi fit inside a step
        y, y_new, f, f_new, Q = _step(tab, t0, h)
        g0, r0, g1, r1 = _ends(y, y_new, f, f_new)
        if g0[0] == 0.0 or g0[1] == 0.0:
            continue
        out = np.zeros(7)
        xs, vs = [], []
        for th in np.linspace(0.0, 1.0, 201):
            stepper.dense_eval(th, y, h, Q, 3, tab.n_poly, out)
            xs.append(out[0])
            vs.append(out[1])
        changes = np.ptp(np.sign(xs)) > 0 or np.ptp(np.sign(vs)) > 0
        inner_dip = changes and np.sign(g0[0]) == np.sign(g1[0]) and np.sign(g0[1]) == np.sign(g1[1])
        n_dips += inner_dip
        n_changes += changes
        if changes:
            assert events.may_cross(active, _signs(g0), g0, r0, g1, r1, h, np.inf), (t0, h)
    assert n_changes > 500
    if name == "dop853":  # dp5's step over half a period is too inaccurate to show a clean inner dip
        assert n_dips > 10
