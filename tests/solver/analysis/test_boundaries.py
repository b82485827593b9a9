"""Boundary types of periodic rolling (paper Sect. 5.1): solver.analysis.boundaries on constructed grids,
on the quick Fig. 11-13 sections (stored as ``boundary_type`` by the derive hook), and refined
by bisection across the grid's boundaries."""

from __future__ import annotations

import numpy as np
import pytest
import xarray as xr

from rimroll import solver
from rimroll.solver.analysis import boundaries as B
from rimroll.solver.engine import outcomes

WEIGHT = 0.6 * 9.81  # m g [N] of Table 1's ball


def _disc(n=31, radius=0.6):
    """A periodic disc in a falling plane: (outcome, r / radius) on an n x n grid over [-1, 1]^2."""
    x = np.linspace(-1.0, 1.0, n)
    X, Y = np.meshgrid(x, x, indexing="ij")
    rel = np.hypot(X, Y) / radius
    outcome = np.where(rel < 1.0, outcomes.PERIODIC_ROLLING, outcomes.FALL_OUT).astype(np.int8)
    return outcome, rel


def _ring(outcome):
    periodic = outcome == outcomes.PERIODIC_ROLLING
    near = np.zeros_like(periodic)
    for ax in (0, 1):
        for s in (1, -1):
            near |= np.roll(periodic, s, ax) != periodic
    return near


def test_deadlock_constructed():
    """F2_min decreases continuously to 0 at the disc's edge, the half period stays finite."""
    outcome, rel = _disc()
    periodic = outcome == outcomes.PERIODIC_ROLLING
    f2 = np.where(periodic, WEIGHT * (1.0 - rel**2), 0.0)
    hp = np.where(periodic, 0.4, np.nan)
    t_end = np.where(periodic, 0.4, 0.3)
    lab = B.classify(outcome, f2, hp, t_end, WEIGHT)
    ring = _ring(outcome)
    assert (lab[ring] == B.DEADLOCK).all()
    assert (lab[~ring] == B.NOT_BOUNDARY).all()


def test_separatrix_constructed():
    """F2_min stays near m g up to the edge (a jump to the fall), the half period grows like
    -log(distance) (orbits near a saddle's homoclinic orbit), the fall side lingers."""
    outcome, rel = _disc()
    periodic = outcome == outcomes.PERIODIC_ROLLING
    f2 = np.where(periodic, WEIGHT * (1.2 - 0.1 * rel), 0.0)
    hp = np.where(periodic, 0.4 - 0.1 * np.log(np.clip(1.0 - rel, 1e-9, None)), np.nan)
    t_end = np.where(periodic, hp, 0.4 - 0.2 * np.log(np.clip(rel - 1.0, 1e-9, None)))
    lab = B.classify(outcome, f2, hp, t_end, WEIGHT)
    ring = _ring(outcome)
    assert (lab[ring] == B.SEPARATRIX).all()
    assert (lab[~ring] == B.NOT_BOUNDARY).all()


def test_slipping_induced_and_undetermined_constructed():
    """A smaller periodic disc inside the rolling-only one: its edge is slipping-induced; without
    the rolling-only grid (and no period growth, no F2_min -> 0) it is undetermined."""
    outcome, rel = _disc(radius=0.4)
    rolling, _ = _disc(radius=0.7)
    periodic = outcome == outcomes.PERIODIC_ROLLING
    f2 = np.where(periodic, WEIGHT, 0.0)
    hp = np.where(periodic, 0.4, np.nan)
    t_end = np.where(periodic, 0.4, 0.5)
    ring = _ring(outcome)
    lab = B.classify(outcome, f2, hp, t_end, WEIGHT, rolling_outcome=rolling)
    assert (lab[ring] == B.SLIPPING_INDUCED).all() and (lab[~ring] == B.NOT_BOUNDARY).all()
    lab = B.classify(outcome, f2, hp, t_end, WEIGHT)
    assert (lab[ring] == B.UNDETERMINED).all()


def test_leading_axes_are_independent_and_no_periodic_means_no_boundary():
    outcome, rel = _disc()
    periodic = outcome == outcomes.PERIODIC_ROLLING
    f2 = np.where(periodic, WEIGHT * (1.0 - rel**2), 0.0)
    hp = np.where(periodic, 0.4, np.nan)
    def stack(a, b):
        return np.stack([a, b])
    falls = np.full_like(outcome, outcomes.FALL_IN)
    lab = B.classify(stack(outcome, falls), stack(f2, f2 * 0), stack(hp, hp * np.nan),
                     stack(np.ones_like(f2), np.ones_like(f2)), WEIGHT)
    assert (lab[1] == B.NOT_BOUNDARY).all()
    assert (lab[0] == B.classify(outcome, f2, hp, np.ones_like(f2), WEIGHT)).all()


def test_bad_arguments():
    with pytest.raises(ValueError, match="weight"):
        B.classify(np.zeros((3, 3)), np.zeros((3, 3)), np.zeros((3, 3)), np.zeros((3, 3)), 0.0)
    with pytest.raises(ValueError, match="shape"):
        B.classify(np.zeros((3, 3)), np.zeros((3, 4)), np.zeros((3, 3)), np.zeros((3, 3)), 1.0)
    with pytest.raises(ValueError, match="thresholds"):
        B.classify(np.zeros((3, 3)), np.zeros((3, 3)), np.zeros((3, 3)), np.zeros((3, 3)), 1.0, f2=1)


@pytest.fixture(scope="module")
def quick_sections(tmp_path_factory):
    from rimroll.study.cli import main

    out = tmp_path_factory.mktemp("boundaries")
    for name in ("fig11", "fig13"):
        assert main(["run", name, "--quick", "--out", str(out), "--no-progress", "--workers", "2"]) == 0
    return {name: xr.open_dataset(out / f"{name}.nc") for name in ("fig11", "fig13")}


def test_boundary_type_is_stored_with_cf_flags(quick_sections):
    ds = quick_sections["fig11"]
    var = ds["boundary_type"]
    assert var.dims == ("scene", "beta", "omega1") and var.dtype == np.int8
    assert var.attrs["flag_meanings"].split() == ["not_boundary", "deadlock", "separatrix", "slipping_induced",
                                                  "undetermined", "separatrix_and_deadlock"]
    assert list(var.attrs["flag_values"]) == [0, 1, 2, 3, 4, 5]
    assert var.attrs["units"] == "1" and var.attrs["long_name"] and "refine_grid" in var.attrs["comment"]
    # the stored labels are the pure functions' on the stored fields: the grid's pairs refined by simulation
    p = solver.Params(mu=float("inf"))
    k = 0
    args = [ds[n].values[k] for n in ("outcome", "f2_min", "half_period", "t_end")]
    beta, omega1 = np.meshgrid(ds["beta"].values, ds["omega1"].values, indexing="ij")
    states = np.stack([beta, omega1, np.full_like(beta, 35.0), np.full_like(beta, 10.0)], axis=-1)
    direct, summary = B.refine_grid(args[0], states, p, 20.0, fallback=B.classify(*args, p.m * p.g), rtol=1e-8,
                                    atol=1e-10, method="dp5")
    assert summary["pairs"] > 0 and summary["refined"] == summary["pairs"]
    assert (direct == var.values[k]).all()


def test_fig11_periodic_region_is_bounded_by_separatrices(quick_sections):
    """Paper Sect. 5.2.3: 'The boundaries of the periodic rolling comes from the separatrices'."""
    lab = quick_sections["fig11"]["boundary_type"].values
    for scene in (0, 1):
        on = lab[scene][lab[scene] != B.NOT_BOUNDARY]
        assert on.size > 0
        assert np.mean(on == B.SEPARATRIX) >= 0.9, np.bincount(on, minlength=5)
        assert not (on == B.DEADLOCK).any()
    assert (lab[2:] == B.NOT_BOUNDARY).all()  # dissipative scenes: no periodic rolling, no boundary


def test_fig13_rolling_has_a_deadlock_region_that_slipping_removes(quick_sections):
    """Fig. 13, rolling only: the second (upper) periodic region is bounded by a deadlock
    boundary; with slipping it vanishes, and what is left is bounded by slipping-induced or
    separatrix cells, never deadlock (paper Sect. 5.2.3)."""
    ds = quick_sections["fig13"]
    lab = ds["boundary_type"].values
    assert (lab[0] == B.DEADLOCK).sum() >= 10
    assert (lab[0] == B.SEPARATRIX).sum() >= 10
    assert not (lab[1] == B.DEADLOCK).any()
    assert (lab[1] == B.SLIPPING_INDUCED).any()


# the column next to omega1 = 0 of the default Fig. 12/13 grids (360 values in [-20, 20] 1/s) and two beta rows
# (240 values in [0.8, 1.8] rad): the last periodic point of the rolling-only island and the first falling one
W1 = float(np.linspace(-20.0, 20.0, 360)[180])
BETA = np.linspace(0.8, 1.8, 240)
GRID_RUN = dict(t_max=20.0, rtol=1e-8, atol=1e-10, method="dp5", workers=1)


def test_a_band_thinner_than_a_cell_holds_a_separatrix_and_a_deadlock():
    """Fig. 12, rolling only, between beta = 1.13473 (periodic) and 1.13054 (falls in): the half
    period peaks without bound at beta ~ 1.1346 (a separatrix) and periodic rolling goes on below it
    until F2_min reaches 0 at beta ~ 1.1323 (deadlock), 0.55 grid steps in all. The grid alone sees
    a separatrix; the refined pair holds both. The scipy reference (an independent integrator)
    confirms both places."""
    from rimroll.solver.analysis.scipy_reference import reference

    p = solver.Params(mu=float("inf"))
    inside, outside = [BETA[80], W1, 65.0, 10.0], [BETA[79], W1, 65.0, 10.0]
    r = B.refine_pairs([inside], [outside], p, **GRID_RUN)
    assert r["type"][0] == B.SEPARATRIX_AND_DEADLOCK and r["refined"][0]
    assert r["separatrix"][0] and not r["separatrix_at_boundary"][0] and r["deadlock"][0]
    b_dead = float(r["periodic"][0, 0])
    b_sep = BETA[80] + float(r["s_peak"][0]) * (BETA[79] - BETA[80])
    assert b_dead == pytest.approx(1.1323, abs=2e-4) and b_sep == pytest.approx(1.1346, abs=2e-4)
    assert 0.4 < (b_sep - b_dead) / (BETA[1] - BETA[0]) < 0.7  # a band of about half a grid step
    assert r["f2_min"][0] < 1e-2 and r["half_period_peak"][0] > 2.0 * r["half_period_start"][0]
    assert r["half_period"][0] == pytest.approx(0.76, abs=0.02)  # finite at the deadlock
    # (2e-5 rad: closer below the boundary the dip of F2 below 0 is too brief for the reference's event search)
    ref = reference([[b_dead + 2e-5, W1, 65.0, 10.0], [b_dead - 2e-5, W1, 65.0, 10.0],
                     [b_sep + 1e-7, W1, 65.0, 10.0], [b_sep - 1e-7, W1, 65.0, 10.0]], p, t_max=20.0, rtol=1e-10)
    assert ref["outcome"].tolist() == [outcomes.PERIODIC_ROLLING, outcomes.FALL_IN, outcomes.PERIODIC_ROLLING,
                                       outcomes.PERIODIC_ROLLING]
    assert min(ref["half_period"][2:]) > 1.8 * r["half_period_start"][0]  # both sides of the peak are slow
    # the grid alone: a separatrix (the half period jumps between the last two periodic rows)
    rows = solver.simulate(np.array([[BETA[i], W1, 65.0, 10.0] for i in range(77, 84)]), p, **GRID_RUN)
    grid = B.classify(*(np.repeat(rows[n][:, None], 3, axis=1) for n in ("outcome", "f2_min", "half_period", "t_end")),
                      p.m * p.g)
    assert grid[80 - 77, 1] == B.SEPARATRIX


def test_fig13_lower_island_edge_is_a_deadlock_that_the_grid_calls_a_separatrix():
    """Fig. 13, rolling only: between beta = 1.23096 (periodic) and 1.22678 the periodic region ends
    at a deadlock with the half period barely changing (0.457 -> 0.479 s); the separatrix lies
    between two periodic rows (beta ~ 1.2337), outside this pair's band."""
    p = solver.Params(mu=float("inf"))
    r = B.refine_pairs([[BETA[103], W1, 105.0, 10.0]], [[BETA[102], W1, 105.0, 10.0]], p, **GRID_RUN)
    assert r["type"][0] == B.DEADLOCK and not r["separatrix"][0]
    assert r["half_period_start"][0] == pytest.approx(0.457, abs=0.005)
    assert r["half_period"][0] == pytest.approx(0.479, abs=0.01)
    assert float(r["periodic"][0, 0]) == pytest.approx(1.2291, abs=2e-4)


def test_refine_grid_types_cells_from_their_pairs_and_slipping_pairs_stop_at_the_first_slip():
    """A column of Fig. 12 across the island's lower edge: only the boundary pair is typed (both cells
    separatrix_and_deadlock), every other cell is not_boundary. With slipping (mu = 1) the same
    edge moves up and is slipping-induced: the state beyond it slips (the refinement stops its runs
    at the first slip) while F2_min of the periodic side stays near 1.25 m g."""
    p = solver.Params(mu=float("inf"))
    rows = np.arange(77, 84)
    states = np.array([[[BETA[i], W1, 65.0, 10.0]] for i in rows])
    out = solver.simulate(states, p, **GRID_RUN)["outcome"]
    labels, summary = B.refine_grid(out, states, p, 20.0, rtol=1e-8, atol=1e-10, method="dp5", workers=1)
    assert summary["pairs"] == 1 and summary["refined"] == 1
    assert labels[:, 0].tolist() == [0, 0, B.SEPARATRIX_AND_DEADLOCK, B.SEPARATRIX_AND_DEADLOCK, 0, 0, 0]
    slip = solver.Params(mu=1.0)
    r = B.refine_pairs([[BETA[89], W1, 65.0, 10.0]], [[BETA[88], W1, 65.0, 10.0]], slip, **GRID_RUN)
    assert r["type"][0] == B.SLIPPING_INDUCED and r["slipped"][0] and not r["deadlock"][0]
    assert r["f2_min"][0] == pytest.approx(1.25 * slip.m * slip.g, rel=0.02)
    assert float(r["periodic"][0, 0]) == pytest.approx(1.1691, abs=5e-4)  # docs/boundary_types.md
    with pytest.raises(ValueError, match="conservative"):
        B.refine_pairs([[BETA[88], W1, 65.0, 10.0]], [[BETA[87], W1, 65.0, 10.0]], solver.Params(mu=1.0, k_r=0.02))


def test_refine_types_a_separatrix_and_a_deadlock_boundary():
    """Bisection across the grid's boundary: Fig. 11's lower edge at omega1 = 0.05 is a
    separatrix (half period grows 4x, F2_min stays ~ m g); Fig. 13's upper region's top edge is
    a deadlock (F2_min -> 0 at a nearly constant half period)."""
    p = solver.Params(mu=float("inf"))
    sep = B.refine([0.975, 0.05, 35.0, 10.0], [0.970, 0.05, 35.0, 10.0], p, n_bisect=24)
    assert sep["type"] == B.SEPARATRIX
    assert sep["f2_min"] > 0.5 * p.m * p.g and sep["half_period"] > 3 * sep["half_period_start"]
    dead = B.refine([1.613, 0.05, 105.0, 10.0], [1.633, 0.05, 105.0, 10.0], p, n_bisect=24)
    assert dead["type"] == B.DEADLOCK
    assert abs(dead["f2_min"]) < 1e-3 * p.m * p.g
    assert dead["half_period"] == pytest.approx(dead["half_period_start"], rel=0.1)
