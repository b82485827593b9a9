"""The ``continuation`` study: outcome fractions, periodic islands and the steady motion along omega2."""

from __future__ import annotations

import numpy as np
import pytest
import xarray as xr

from rimroll.workflows import continuation


def test_island_events_by_overlap():
    grid = np.zeros((6, 8, 8), bool)
    grid[1, 1:3, 1:7] = True  # born
    grid[2, 1:3, 1:3] = grid[2, 1:3, 5:7] = True  # the island splits in two
    grid[3, 1:3, 1:7] = True  # they merge again
    grid[4, 1:3, 1:7] = grid[4, 5:7, 1:3] = True  # a second island is born beside it
    grid[5, 5:7, 1:3] = True  # the first vanishes
    ev = continuation.island_events(grid)
    c = continuation
    assert ev.tolist() == [0, c.BORN, c.SPLIT, c.MERGED, c.BORN, c.VANISHED]


def test_islands_are_4_connected_regions():
    mask = np.zeros((6, 6), bool)
    mask[0, 0] = mask[1, 1] = True  # diagonal neighbours: two islands
    mask[3:5, 3:6] = True
    assert continuation.islands(mask) == (3, 8)


@pytest.fixture(scope="module")
def quick(tmp_path_factory):
    from rimroll.study.cli import main

    out = tmp_path_factory.mktemp("continuation")
    assert main(["run", "continuation", "--quick", "--set", "omega2=35,65,105", "--out", str(out),
                 "--no-progress"]) == 0
    return xr.open_dataset(out / "continuation.nc")


def test_fractions_sum_to_one_and_count_the_cells(quick):
    total = sum(quick[f"fraction_{name}"] for name, _ in continuation.FRACTIONS)
    np.testing.assert_allclose(total.values, 1.0)
    periodic = (quick["outcome"] == 2).mean(("beta", "omega1"))
    np.testing.assert_allclose(quick["fraction_periodic"].values, periodic.values)
    assert quick.attrs["setting_adaptive"] == 1 and (quick["refine_level"] == -1).any()


def test_steady_motion_along_omega2_matches_the_paper_sections(quick):
    # README "Where rimroll reads the paper": omega20 = 35: beta0 = 1.1246 rad, region A; 65: 1.2822, A; 105: 1.3740,
    # not realisable with a 10 m/s throw (it needs 10.40 m/s)
    np.testing.assert_allclose(quick["steady_beta0"].values, [1.1246, 1.2822, 1.3740], atol=1e-4)
    assert quick["steady_region"].values.tolist() == [1, 1, 0]
    assert (quick["steady_h"] < 0).all()  # stable (54)


def test_rolling_only_islands_one_then_two_at_fig13(quick):
    # the full Fig. 13 rolling-only map has two periodic islands, Figs. 11 and 12 one
    assert quick["island_count"].values.tolist() == [1, 1, 2]
    # 35 -> 65 1/s is too large a step for overlap (the island moved off itself: born and vanished);
    # at 105 a second island appears
    c = continuation
    assert quick["island_event"].values[0] == 0 and quick["island_event"].values[2] & (c.BORN | c.SPLIT)
    assert (quick["island_area"] > 0).all()
