"""The single-point impact of the ball (solver.physics.impact) against closed forms and energy bounds."""

from __future__ import annotations

import math

import numpy as np
import pytest

from rimroll.solver.physics.contact_times import first_ring_contact
from rimroll.solver.physics.impact import impact, kinetic_energy
from rimroll.solver.physics.shot_geometry import ring_normal

R_BALL, J = 0.12, 2.0 / 3.0  # paper Table 1


def _random_impacts(seed, count, e=None, mu=None):
    rng = np.random.default_rng(seed)
    for _ in range(count):
        n = rng.normal(size=3)
        n /= np.linalg.norm(n)
        v = rng.normal(size=3) * 5.0
        v -= (abs(v @ n) + 0.01) * n if v @ n > 0 else 0.0 * n  # approaching
        yield (tuple(v), tuple(rng.normal(size=3) * 40.0), tuple(n), rng.uniform(0.2, 1.0),
               rng.uniform() if e is None else e, rng.uniform(0.0, 2.0) if mu is None else mu)


def test_elastic_frictionless_impact_conserves_energy():
    """e = 1, mu = 0: the kinetic energy is the same to round-off, the spin unchanged."""
    for v, w, n, j, e, mu in _random_impacts(1, 2000, e=1.0, mu=0.0):
        v2, w2, _ = impact(v, w, n, R_BALL, j, e, mu)
        before, after = kinetic_energy(v, w, 1.0, R_BALL, j), kinetic_energy(v2, w2, 1.0, R_BALL, j)
        assert after == pytest.approx(before, rel=1e-13)
        assert w2 == pytest.approx(w, abs=1e-12)


def test_random_impacts_never_gain_energy():
    """5000 seeded impacts (any normal, e in [0, 1], mu in [0, 2], j in [0.2, 1]): energy never rises,
    and the normal rebound is -e times the approach."""
    for v, w, n, j, e, mu in _random_impacts(2, 5000):
        v2, w2, _ = impact(v, w, n, R_BALL, j, e, mu)
        before = kinetic_energy(v, w, 1.0, R_BALL, j)
        assert kinetic_energy(v2, w2, 1.0, R_BALL, j) <= before * (1.0 + 1e-14)
        assert np.dot(v2, n) == pytest.approx(-e * np.dot(v, n), rel=1e-12, abs=1e-12)


@pytest.mark.parametrize("j", [2.0 / 3.0, 0.4])
def test_stick_slide_switch_against_the_closed_form(j):
    """A ball hitting the plane z = 0 (n = z) with tangential contact speed u: it sticks, leaving the
    centre with u / (1 + j) (the contact point at rest: v' = r w'), while u <= (1 + 1/j) mu (1 + e) v_n;
    beyond it slides and loses mu (1 + e) v_n of tangential speed."""
    e, mu, v_n = 0.6, 0.3, 2.0
    edge = (1.0 + 1.0 / j) * mu * (1.0 + e) * v_n
    for u, sticks in ((0.999 * edge, True), (1.001 * edge, False), (0.2 * edge, True), (3.0 * edge, False)):
        v2, w2, stuck = impact((u, 0.0, -v_n), (0.0, 0.0, 0.0), (0.0, 0.0, 1.0), R_BALL, j, e, mu)
        assert stuck == sticks
        expected = u / (1.0 + j) if sticks else u - mu * (1.0 + e) * v_n
        assert v2[0] == pytest.approx(expected, rel=1e-13)
        assert v2[2] == pytest.approx(e * v_n, rel=1e-13)
        # contact point velocity along x: v_x + (w x (-r z))_x = v_x - r w_y
        slip_after = v2[0] - R_BALL * w2[1]
        assert slip_after == pytest.approx(0.0 if sticks else u - (1.0 + 1.0 / j) * mu * (1.0 + e) * v_n, abs=1e-12)


def test_drop_on_top_of_the_tube_bounces_straight_up():
    """A ball dropped without spin onto the top of the ring's tube (beta = pi/2, paper Fig. 2) touches
    it when its centre is rho above the tube's centre circle and leaves straight up with e v, no spin."""
    R, a, v, e = 0.225, 0.01, 3.0, 0.6
    rho, z0 = R_BALL + a, 0.5
    # centre at (R, 0, z0) falling at v: z(t) = z0 - v t - g t^2 / 2
    g = 9.81
    t_hit = first_ring_contact([R, 0.0], [0.0], [z0, -v, -0.5 * g], 1.0, R, rho, leaving=False)
    t_exact = (-v + math.sqrt(v * v + 2.0 * g * (z0 - rho))) / g
    assert t_hit == pytest.approx(t_exact, rel=1e-13)
    n = ring_normal(R, 0.0, rho, R)
    assert n == pytest.approx((0.0, 0.0, 1.0), abs=1e-15)
    v_in = v + g * t_exact
    v2, w2, _ = impact((0.0, 0.0, -v_in), (0.0, 0.0, 0.0), n, R_BALL, J, e, 0.5)
    assert v2 == pytest.approx((0.0, 0.0, e * v_in), abs=1e-14)
    assert w2 == pytest.approx((0.0, 0.0, 0.0), abs=1e-14)
