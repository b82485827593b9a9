"""Boundary curves of outcome grids (solver.analysis.boundary_curves, study.curve_variables): the
polylines separate exactly the cells of different outcome, carry the right labels, round-trip
through the results file and are what the plot draws."""

from __future__ import annotations

import numpy as np
import pytest
import xarray as xr

from rimroll.solver.analysis import boundaries
from rimroll.solver.analysis import boundary_curves as bc
from rimroll.solver.engine import outcomes


def _blobs(shape, n_codes, seed, smooth=3):
    """A random grid of ``n_codes`` codes in blobs (smoothed noise, quantised)."""
    rng = np.random.default_rng(seed)
    x = rng.normal(size=shape)
    for _ in range(smooth):
        x = (x + np.roll(x, 1, 0) + np.roll(x, -1, 0) + np.roll(x, 1, 1) + np.roll(x, -1, 1)) / 5
    edges = np.quantile(x, np.linspace(0, 1, n_codes + 1)[1:-1])
    return np.digitize(x, edges)


GRIDS = [_blobs((17, 23), 2, 0), _blobs((30, 20), 3, 1), _blobs((25, 25), 4, 2, smooth=1),
         np.random.default_rng(3).integers(0, 3, (9, 11)),  # noise: junctions and checkerboards everywhere
         np.add.outer(np.arange(6), np.arange(7)) % 2,  # a checkerboard
         _blobs((1, 15), 2, 4, smooth=0), _blobs((12, 1), 3, 5, smooth=0)]


def _links(codes):
    """{midpoint (row, col): (cell, cell)} of every link between cells of different code."""
    n, m = codes.shape
    out = {}
    for i, j in zip(*np.nonzero(codes[:, :-1] != codes[:, 1:])):
        out[(float(i), j + 0.5)] = ((i, j), (i, j + 1))
    for i, j in zip(*np.nonzero(codes[:-1, :] != codes[1:, :])):
        out[(i + 0.5, float(j))] = ((i, j), (i + 1, j))
    return out


def _random_types(codes, seed):
    rng = np.random.default_rng(seed)
    n, m = codes.shape
    return rng.integers(0, 3, (n, m - 1)).astype(np.int8), rng.integers(0, 3, (n - 1, m)).astype(np.int8)


@pytest.mark.parametrize("k", range(len(GRIDS)))
def test_every_boundary_link_lies_on_exactly_one_curve_and_none_else(k):
    codes = GRIDS[k]
    c = bc.trace(codes, _random_types(codes, k))
    links = _links(codes)
    on_curves = []
    for q in range(len(c)):
        pts = c.curve(q)
        if (pts[0] == pts[-1]).all():  # closed: the first point once
            pts = pts[:-1]
        on_curves += [tuple(p) for p in pts.tolist() if tuple(p) in links or (p[0] % 1 == 0) != (p[1] % 1 == 0)]
    assert sorted(on_curves) == sorted(links)  # each differing link's midpoint once, no other link's midpoint


@pytest.mark.parametrize("k", range(len(GRIDS)))
def test_no_segment_crosses_a_uniform_region(k):
    codes = GRIDS[k]
    n, m = codes.shape
    c = bc.trace(codes)
    assert (c.sizes >= 2).all() and c.points.shape == (c.sizes.sum(), 2)
    for q in range(len(c)):
        pts = c.curve(q)
        for a, b in zip(pts[:-1], pts[1:]):
            r0, c0 = np.floor((a + b) / 2).astype(int)
            # the square (or border half-cell) holding the segment: both ends inside it
            assert r0 <= min(a[0], b[0]) and max(a[0], b[0]) <= r0 + 1
            assert c0 <= min(a[1], b[1]) and max(a[1], b[1]) <= c0 + 1
            rows = sorted({min(max(r0, 0), n - 1), min(max(r0 + 1, 0), n - 1)})
            cols = sorted({min(max(c0, 0), m - 1), min(max(c0 + 1, 0), m - 1)})
            assert np.unique(codes[np.ix_(rows, cols)]).size >= 2, (q, a, b)


@pytest.mark.parametrize("k", range(len(GRIDS)))
def test_each_curve_is_labelled_by_the_cells_and_links_it_separates(k):
    codes = GRIDS[k]
    types = _random_types(codes, 10 + k)
    c = bc.trace(codes, types)
    links = _links(codes)
    for q in range(len(c)):
        assert c.code_a[q] < c.code_b[q]
        for p in map(tuple, c.curve(q).tolist()):
            if p in links:
                (i1, j1), (i2, j2) = links[p]
                assert {codes[i1, j1], codes[i2, j2]} == {c.code_a[q], c.code_b[q]}
                t = types[0][i1, j1] if i1 == i2 else types[1][i1, j1]
                assert c.link_type[q] == t


def test_curves_join_through_the_grid_and_close_around_an_island():
    i, j = np.mgrid[:40, :50]
    codes = ((i - 20.3) ** 2 + (j - 24.6) ** 2 < 12.0 ** 2).astype(int)
    c = bc.trace(codes)
    assert len(c) == 1
    pts = c.curve(0)
    assert (pts[0] == pts[-1]).all()  # closed
    r = np.hypot(pts[:, 0] - 20.3, pts[:, 1] - 24.6)
    assert np.abs(r - 12.0).max() <= 0.5 + 1e-9  # within half a cell of the circle (a staircase: up to 0.71)
    # a straight boundary: one straight curve from edge to edge, with its two ends half a cell out
    c = bc.trace(np.repeat([[0, 0, 1, 1, 1]], 4, axis=0))
    assert len(c) == 1 and c.curve(0)[[0, -1], 0].tolist() == [-0.5, 3.5] and set(c.curve(0)[:, 1]) == {1.5}


def test_curves_split_where_the_type_changes_and_at_junctions():
    codes = np.zeros((6, 6), int)
    codes[:, 3:] = 1
    cols = np.zeros((6, 5), np.int8)
    cols[3:, 2] = 4  # the lower half of the boundary of another type
    c = bc.trace(codes, (cols, np.zeros((5, 6), np.int8)))
    assert sorted(c.link_type.tolist()) == [0, 4]
    ends = {tuple(c.curve(q)[e]) for q in range(2) for e in (0, -1)}
    assert (2.5, 2.5) in ends  # they meet half-way between the two link midpoints
    three = np.zeros((4, 4), int)
    three[:, 2:] = 1
    three[2:, :] = 2
    c = bc.trace(three)
    assert len(c) == 3 and all((1.5, 1.5) in map(tuple, c.curve(q).tolist()) for q in range(3))


def test_uniform_grid_has_no_curve_and_bad_input_is_refused():
    c = bc.trace(np.ones((5, 4), int))
    assert len(c) == 0 and c.points.shape == (0, 2)
    with pytest.raises(ValueError, match="2-D grid"):
        bc.trace(np.ones(5))
    with pytest.raises(ValueError, match="link_type must have shapes"):
        bc.trace(np.ones((3, 4)), (np.zeros((3, 4)), np.zeros((2, 4))))


def test_on_axes_maps_index_units_onto_the_grid():
    beta, w1 = np.linspace(0.8, 1.8, 11), np.linspace(-20, 20, 5)
    b, w = bc.on_axes([[0, 0], [-0.5, 4.5], [2.5, 1.5]], beta, w1)
    assert b == pytest.approx([0.8, 0.75, 1.05]) and w == pytest.approx([-20, 25, -5])


def test_link_types_take_the_pair_type_and_leave_other_boundaries_untyped():
    P, IN, OUT = outcomes.PERIODIC_ROLLING, outcomes.FALL_IN, outcomes.FALL_OUT
    outcome = np.array([[IN, P, OUT],
                        [IN, OUT, OUT]])
    cell = np.array([[boundaries.SEPARATRIX, boundaries.DEADLOCK, boundaries.DEADLOCK],
                     [0, boundaries.DEADLOCK, 0]], np.int8)
    cols, rows = bc.link_types(outcome, cell)
    # IN|P: separatrix and deadlock differ, the later in the priority order (separatrix) is the pair's
    assert cols.tolist() == [[boundaries.SEPARATRIX, boundaries.DEADLOCK], [0, 0]]
    assert rows.tolist() == [[0, boundaries.DEADLOCK, 0]]  # IN|IN, P|OUT, OUT|OUT
    with pytest.raises(ValueError, match="one shape"):
        bc.link_types(outcome, cell[:1])


def _section(path):
    from rimroll.study.io import open_result

    return open_result(path)


@pytest.fixture(scope="module")
def fig12(tmp_path_factory):
    from rimroll.study.api import run

    out = tmp_path_factory.mktemp("curves")
    return run("fig12", quick=True, out=out, progress=False, n_beta=12, n_omega1=18), out


def test_the_file_stores_the_curves_of_every_scene_as_a_ragged_array(fig12):
    from rimroll.study import curve_variables as curves

    path = fig12[1] / "fig12.nc"
    ds = _section(path)  # the validating reader
    plain = xr.open_dataset(path)  # plain xarray
    for name in curves.NAMES:
        assert name in plain.variables
        np.testing.assert_array_equal(plain[name].values, ds[name].values)
    assert plain["boundary_node_count"].values.sum() == plain.sizes["boundary_point"]
    for k, label in enumerate(ds["scene"].values):
        sel = ds.isel(scene=k)
        expect = curves.traced(sel["outcome"].values, sel["boundary_type"].values, ds["beta"].values,
                               ds["omega1"].values)
        stored = curves.of_scene(ds, str(label))
        assert len(stored) == len(expect) > 0
        for (p, t), (q, u) in zip(stored, expect):
            np.testing.assert_array_equal(p, q)
            assert t == u
    # the typed curves follow the boundary_type of the cells: a periodic boundary in the conservative scenes
    kinds = set(ds["boundary_curve_type"].values[ds["boundary_curve_scene"].values == 0].tolist())
    assert kinds - {boundaries.NOT_BOUNDARY}


def test_the_plot_draws_the_stored_curves(fig12):
    from matplotlib.collections import LineCollection

    from rimroll.study import curve_variables as curves
    from rimroll.study.registry import get

    ds = _section(fig12[1] / "fig12.nc")
    fig = get("fig12").plot(ds)
    ax = fig.axes[0]  # rolling only
    drawn = [seg for c in ax.collections if isinstance(c, LineCollection) and (c.get_gid() or "").startswith(
        "boundary_") for seg in c.get_segments()]
    stored = [p for p, _ in curves.of_scene(ds, "rolling_only")]
    assert sorted(map(lambda a: a.tobytes(), drawn)) == sorted(map(lambda a: a.tobytes(), stored))


def test_a_map_without_boundaries_stores_no_curves_and_untyped_sections_trace_as_not_boundary():
    from rimroll.study import curve_variables as curves

    beta, w1 = np.linspace(0.8, 1.8, 6), np.linspace(-20, 20, 8)
    uniform = np.full((2, 6, 8), outcomes.FALL_IN)
    assert curves.variables(uniform, np.zeros_like(uniform), beta, w1, ["a", "b"]) == {}
    two = uniform.copy()
    two[1, :, 4:] = outcomes.FALL_OUT  # a boundary in the second scene only
    v = curves.variables(two, np.zeros_like(two), beta, w1, ["a", "b"])
    assert v["boundary_curve_scene"][1].tolist() == [1] and v["boundary_node_count"][1].tolist() == [8]
    assert set(v["boundary_omega1"][1]) == {0.0} and v["boundary_beta"][1][[0, -1]] == pytest.approx([0.7, 1.9])
    t = curves.trace_scene(two[1], None, beta, w1)  # no boundary types (an outcome-cube slice)
    assert t["type"].tolist() == [boundaries.NOT_BOUNDARY]


def test_files_of_two_sections_combine_and_keep_each_ones_curves(fig12, tmp_path):
    """Two fig12 files of different omega2 (different numbers of curves and points) combine with
    xr.concat along omega2 (the notebook's and open_mfdataset's way), and each slice of the combined
    dataset gives back the curves of its own file."""
    from rimroll.study import curve_variables as curves
    from rimroll.study.api import run

    other = run("fig12", quick=True, out=tmp_path, progress=False, n_beta=12, n_omega1=18, omega2=35.0)
    first = xr.open_dataset(fig12[1] / "fig12.nc")
    assert first.sizes["boundary_point"] != other.sizes["boundary_point"]
    both = xr.concat([first, other], dim="omega2", join="outer", combine_attrs="drop_conflicts")
    for k, one in enumerate((first, other)):
        for label in one["scene"].values:
            mine, combined = curves.of_scene(one, str(label)), curves.of_scene(both.isel(omega2=k), str(label))
            assert len(mine) == len(combined) > 0
            for (p, t), (q, u) in zip(mine, combined):
                np.testing.assert_array_equal(p, q)
                assert t == u
