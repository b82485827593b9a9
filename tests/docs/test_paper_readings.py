"""The page "Where rimroll reads the paper" (docs/explanation/paper-readings.md), checked: the split
of Prop. 6 at m g rho, the alternative normalisation of the dissipation (83) and Sect. 5.3 under both readings, and the
throw that the steady motion of Fig. 13 needs."""

from __future__ import annotations

import re

import numpy as np
import pytest
from scipy.optimize import brentq

from rimroll import solver
from rimroll.solver.analysis import steady, trajectory
from rimroll.solver.physics import rolling
from rimroll.solver.physics.params import moment_normalised
from tests.helpers.dissipation_readings import (
    DISSIPATIONS,
    FIGURES,
    ISLANDS,
    READINGS,
    all_counts,
    dissipative_params,
    table,
)
from tests.helpers.paths import ROOT

PAGE = (ROOT / "docs" / "explanation" / "paper-readings.md").read_text()
P_ROLL = solver.Params(mu=float("inf"))


# ----------------------------------------------------------------------------- energy (60), Prop. 6
def _swings(e, p=P_ROLL, beta=0.4):
    """omega1 changes sign within 10 s from (beta, omega1, 0, 0) with energy (60) E = e m g rho."""
    w1 = np.sqrt(2 * (e - np.sin(beta)) * p.g * p.rho / ((1 + p.j) * p.r**2))
    return trajectory.omega1_zeros(np.array([beta, w1, 0.0, 0.0]), p, 10.0, n_zeros=1, rtol=1e-12,
                                   atol=1e-14)[0].size > 0


def test_prop6_measured_split_is_at_m_g_rho():
    lo, hi = 0.9, 1.1
    assert _swings(lo) and not _swings(hi)
    while hi - lo > 1e-8:
        mid = 0.5 * (lo + hi)
        lo, hi = (mid, hi) if _swings(mid) else (lo, mid)
    assert 0.5 * (lo + hi) == pytest.approx(1.0, abs=1e-7)
    # the printed split E = m g r is at r/rho of m g rho, where the ball still swings
    assert P_ROLL.r / P_ROLL.rho == pytest.approx(0.923, abs=5e-4) and _swings(0.95)


# ----------------------------------------------------------------------------- dissipation (83)
def test_moment_normalisation_rates_and_power():
    p = solver.Params(k_r=0.02, k_d=0.02)
    q = moment_normalised(p)
    assert (p.k_r, p.k_d) == (0.02, 0.02)  # the default reading is unchanged
    assert q.k_r == pytest.approx(0.02 * (2 / 3) * 0.225**2 / ((5 / 3) * 0.12**2), rel=1e-14)
    assert q.k_d == pytest.approx(0.02 * 0.225**2 / 0.12**2, rel=1e-14)
    assert f"{q.k_r:.4f} 1/s" in PAGE and f"{q.k_d:.4f} 1/s" in PAGE
    # the power of the contact moment is that of (82) with C_r = C_d = 0.02 j m R^2
    w = np.array([3.0, -40.0, 12.0])
    c = 0.02 * p.j * p.m * p.R**2
    assert rolling.dissipated_power(*w, q.as_array()) == pytest.approx(-c * (w[0]**2 + w[1]**2 + w[2]**2), rel=1e-13)
    # and rimroll's reading is the rates of (83) as printed: -k omega in the rolling equations
    rates = np.array(rolling.rolling_rhs(1.0, *w, p.as_array())) - np.array(rolling.rolling_rhs(1.0, *w, p.replace(
        k_r=0, k_d=0).as_array()))
    np.testing.assert_allclose(rates[1:], -0.02 * w, rtol=1e-12)


def _conclusions_hold(c, in_fraction):
    """Sect. 5.3.2 on ``all_counts``; in_fraction[fig, island]: the least fraction that falls in
    with rolling resistance in Figs. 11 and 12."""
    for fig in FIGURES:
        for name in ISLANDS:
            for reading in READINGS:
                n_in, n_out, n_rim = c[fig][name, "drilling", reading]
                assert n_in == n_rim == 0 and n_out > 0, (fig, name, reading)  # drilling: all out
                n_in, n_out, n_rim = c[fig][name, "rolling_resistance", reading]
                assert n_rim == 0, (fig, name, reading)
                if fig == "Fig. 13":
                    assert n_in == 0 and n_out > 0  # Fig. 13: out for both dissipations
                else:  # Figs. 11, 12: rolling resistance pushes them in
                    assert n_in / (n_in + n_out) >= in_fraction[fig, name], (fig, name, reading, n_in, n_out)


def test_section_53_conclusions_hold_under_both_readings_on_a_coarse_grid():
    _conclusions_hold(all_counts(48, 72), {("Fig. 11", "rolling_only"): 1.0, ("Fig. 11", "slipping"): 1.0,
                                           ("Fig. 12", "rolling_only"): 0.75, ("Fig. 12", "slipping"): 1.0})
    assert dissipative_params("drilling", "moment").k_d == pytest.approx(0.0703125)
    assert set(DISSIPATIONS) == {"drilling", "rolling_resistance"}


@pytest.mark.slow
def test_readme_table_is_what_the_check_computes_on_the_default_grids():
    counted = all_counts(240, 360)
    for row in table(counted):
        assert row in PAGE, row
    _conclusions_hold(counted, {("Fig. 11", "rolling_only"): 0.99, ("Fig. 11", "slipping"): 0.99,
                                ("Fig. 12", "rolling_only"): 0.8, ("Fig. 12", "slipping"): 1.0})
    in12 = [counted["Fig. 12"]["rolling_only", "rolling_resistance", r] for r in READINGS]
    shares = [f"{round(100 * n_in / (n_in + n_out))} %" for n_in, n_out, _ in in12]
    text = " ".join(PAGE.split())
    assert f"rolling-only island of Fig. 12, {shares[0]} fall in with rimroll's rate and {shares[1]}" in text


# ----------------------------------------------------------------------------- Fig. 13 and region A
def _steady_of_figure(omega20, p):
    return brentq(lambda b: steady.omega20(b, 10.0, p) - omega20, 0.5, 1.5, xtol=1e-14)


def test_fig13_steady_motion_needs_a_throw_of_10_40_and_lies_outside_region_a_at_10():
    p = solver.Params()
    beta0 = _steady_of_figure(105.0, p)
    v = float(steady.throw_speed(beta0, 10.0, p))
    assert f"{beta0:.4f}" == "1.3740" and f"{v:.2f}" == "10.40"
    assert f"beta0 = {beta0:.4f} rad" in PAGE and f"throw of {v:.2f} m/s" in PAGE
    assert steady.stability(beta0, 10.0, p) < 0 and steady.rolls_without_slipping(beta0, 10.0, p)
    assert steady.realisable_region(beta0, 10.0, p, v_throw=10.0) == steady.REGION_NONE
    assert steady.realisable_region(beta0, 10.0, p, v_throw=v + 1e-9) == steady.REGION_A
    for omega20 in (35.0, 65.0):  # Figs. 11 and 12 are inside
        assert steady.realisable_region(_steady_of_figure(omega20, p), 10.0, p, v_throw=10.0) == steady.REGION_A


def test_readme_comment_lines_are_what_the_block_prints():
    p = solver.Params()
    for omega20 in (35.0, 65.0, 105.0):
        beta0 = _steady_of_figure(omega20, p)
        v = float(steady.throw_speed(beta0, 10.0, p))
        region = int(steady.realisable_region(beta0, 10.0, p, v_throw=10.0))
        line = (f"# omega20 = {omega20:g}: beta0 = {beta0:.4f} rad, throw {v:.2f} m/s, stable True, rolls True, "
                f"region {region}")
        assert line in PAGE, line
    assert re.search(r"^\| Fig\. 13 \| slipping \|", PAGE, re.M)
