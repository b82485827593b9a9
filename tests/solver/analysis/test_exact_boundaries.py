"""Exact boundaries (solver.analysis.exact_boundaries): crossings of grid lines bisected to adjacent
doubles, their kinds, the curves through them, and the reduced solver's crossings of Fig. 11."""

from __future__ import annotations

import numpy as np
import pytest

from rimroll import solver
from rimroll.solver.analysis import exact_boundaries as eb
from rimroll.solver.engine import outcomes

ROWS, COLS = np.linspace(0.8, 1.8, 13), np.linspace(-20.0, 20.0, 17)


def edge(w):
    """A known boundary beta = edge(omega1): periodic below, falling in above; falling out for omega1 > 15."""
    return 1.2 + 0.01 * w


def synthetic(b, w):
    b, w = np.asarray(b, float), np.asarray(w, float)
    periodic = b < edge(w)
    out = np.where(w > 15.0, outcomes.FALL_OUT, np.where(periodic, outcomes.PERIODIC_ROLLING, outcomes.FALL_IN))
    return {"outcome": out, "f2_min": np.where(out == outcomes.PERIODIC_ROLLING, 10.0 * (edge(w) - b), 0.0)}


def codes_of(run, rows=ROWS, cols=COLS):
    b, w = np.meshgrid(rows, cols, indexing="ij")
    return np.asarray(run(b.ravel(), w.ravel())["outcome"]).reshape(b.shape)


def test_every_crossing_is_bisected_to_adjacent_doubles_on_the_known_boundary():
    codes = codes_of(synthetic)
    c = eb.bisect_links(synthetic, ROWS, COLS, codes, weight=6.0)
    assert c.at.size == len(eb.links(codes)[0]) > 10 and c.converged.all()
    assert (np.nextafter(c.lo, c.hi) == c.hi).all()
    assert (np.asarray(synthetic(*_states(c, c.lo))["outcome"]) == c.code_lo).all()
    assert (np.asarray(synthetic(*_states(c, c.hi))["outcome"]) == c.code_hi).all()
    rolling = c.axis == 0  # beta varies: the crossing is edge(omega1) to rounding
    grazing = rolling & np.isin(c.code_lo, outcomes.PERIODIC_ROLLING)
    assert grazing.any() and np.abs(c.at[grazing] - edge(COLS[c.j[grazing]])).max() <= 4e-16
    assert (c.kind[grazing] == eb.KINDS.index("grazing")).all()
    flight = np.isin(c.code_lo, eb.FALLS) & np.isin(c.code_hi, eb.FALLS)
    assert flight.any() and (c.kind[flight] == eb.KINDS.index("falls")).all()
    assert np.abs(c.at[flight & (c.axis == 1)] - 15.0).max() <= 4e-15


def _states(c, x):
    along = c.axis == 0
    return np.where(along, x, ROWS[c.i]), np.where(along, COLS[c.j], x)


def test_the_curves_pass_through_the_crossings_and_a_coarse_map_is_within_half_a_cell():
    codes = codes_of(synthetic)
    c = eb.bisect_links(synthetic, ROWS, COLS, codes, weight=6.0)
    curves, r, w = eb.exact_curves(c, ROWS, COLS, codes)
    rr, ww = _states(c, c.at)
    for a, b in zip(rr, ww):  # every crossing is a point of a curve
        assert np.hypot(r - a, w - b).min() == 0.0
    grazing = c.kind == eb.KINDS.index("grazing")
    assert grazing.sum() > 10 and np.abs(rr[grazing] - edge(ww[grazing])).max() <= 4e-16
    d = eb.line_distances(c, ROWS, COLS, codes)  # the traced map's own curves: at the links' midpoints
    spacing = np.where(c.axis == 0, ROWS[1] - ROWS[0], COLS[1] - COLS[0])
    assert np.isfinite(d).all() and (d <= 0.5 * spacing + 1e-12).all() and (d > 0).any()


@pytest.mark.slow
def test_the_reduced_solver_locates_fig11_rolling_boundaries_to_adjacent_doubles():
    p = solver.Params(mu=np.inf)

    def run(b, w):
        states = np.stack([b, w, np.full_like(b, 35.0), np.full_like(b, 10.0)], axis=-1)
        return solver.simulate(states, p, t_max=20.0, method="reduced", workers=1)
    rows, cols = np.linspace(0.8, 1.8, 24), np.linspace(-20.0, 20.0, 36)
    codes = codes_of(run, rows, cols)
    c = eb.bisect_links(run, rows, cols, codes, p.m * p.g)
    assert c.converged.all() and (np.nextafter(c.lo, c.hi) == c.hi).all()
    rim = ~np.isin(c.code_lo, eb.FALLS) | ~np.isin(c.code_hi, eb.FALLS)
    assert rim.any() and (c.kind[rim] != eb.KINDS.index("falls")).all()
