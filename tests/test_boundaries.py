"""Boundary types of periodic rolling (paper Sect. 5.1): solver.boundaries on constructed grids,
on the quick Fig. 11-13 sections (stored as ``boundary_type`` by the derive hook), and refined
by bisection across the grid's boundaries."""

from __future__ import annotations

import numpy as np
import pytest
import xarray as xr

import solver
from solver import boundaries as B
from solver import outcomes

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
    stack = lambda a, b: np.stack([a, b])
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
    from study.cli import main

    out = tmp_path_factory.mktemp("boundaries")
    for name in ("fig11", "fig13"):
        assert main(["run", name, "--quick", "--out", str(out), "--no-progress", "--workers", "2"]) == 0
    return {name: xr.open_dataset(out / f"{name}.nc") for name in ("fig11", "fig13")}


def test_boundary_type_is_stored_with_cf_flags(quick_sections):
    ds = quick_sections["fig11"]
    var = ds["boundary_type"]
    assert var.dims == ("scene", "beta", "omega1") and var.dtype == np.int8
    assert var.attrs["flag_meanings"].split() == ["not_boundary", "deadlock", "separatrix", "slipping_induced",
                                                  "undetermined"]
    assert list(var.attrs["flag_values"]) == [0, 1, 2, 3, 4]
    assert var.attrs["units"] == "1" and var.attrs["long_name"]
    # the stored labels are the pure function's on the stored fields
    p = solver.Params()
    k = 0
    direct = B.classify(ds["outcome"].values[k], ds["f2_min"].values[k], ds["half_period"].values[k],
                        ds["t_end"].values[k], p.m * p.g)
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
