"""Figures a reader can trust: properties of the drawn figures, not their pixels.

Legend entries equal the categories drawn, axis limits equal the computed domain, one outcome
palette for every outcome figure, contour labels clear of the steady-motion star and of each
other, one label per realisable region and sign.
"""

from __future__ import annotations

import numpy as np
import pytest
import xarray as xr
from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.collections import LineCollection
from matplotlib.colors import to_rgba

from rimroll import solver
from rimroll.solver.analysis import boundaries
from rimroll.study import plotting as P
from rimroll.study.cli import main
from rimroll.study.registry import get


def _run(out, name, *sets):
    args = ["run", name, "--quick", "--out", str(out), "--no-progress"]
    for s in sets:
        args += ["--set", s]
    assert main(args) == 0
    return xr.open_dataset(out / f"{name}.nc")


@pytest.fixture(scope="module")
def fig12(tmp_path_factory):
    return _run(tmp_path_factory.mktemp("fig12"), "fig12")


def _rendered(fig):
    FigureCanvasAgg(fig).draw()
    return fig


# ------------------------------------------------------------------ one palette
def test_one_palette_object_for_every_outcome_figure():
    from rimroll.workflows import cubes, outcome_grids

    assert outcome_grids.PALETTE is P.OUTCOME_PALETTE
    assert cubes.PALETTE is P.OUTCOME_PALETTE
    pal = P.OUTCOME_PALETTE
    assert set(pal.codes) == set(solver.OUTCOME_MEANINGS)
    colours = [pal.colour(c) for c in pal.codes]
    assert len(set(colours)) == len(colours)  # one colour, one outcome
    assert all(pal.label(c) != pal.names[c] for c in pal.codes)  # words, not flag names


def test_palette_grows_with_the_outcome_codes():
    meanings = {**solver.OUTCOME_MEANINGS, 4: "steady_motion: on an exact steady motion", 9: "new_thing: x"}
    pal = P.OutcomePalette(meanings)
    assert pal.label(4) == "steady motion (exact)" and pal.colour(4) == P.OUTCOME_COLOUR["steady_motion"]
    assert pal.label(9) == "new thing"
    assert len({pal.colour(c) for c in pal.codes}) == len(pal.codes)
    cmap, norm = pal.cmap_norm()
    assert to_rgba(cmap(norm(9))) == to_rgba(pal.colour(9))


def test_outcome_cube_uses_the_palette_colours(tmp_path):
    ds = _run(tmp_path, "outcome-cube", "mu=1", "k_r=0,0.02", "k_d=0", "omega2=65", "n_beta=6", "n_omega1=6")
    fig = get("outcome-cube").plot(ds)
    drawn = {to_rgba(line.get_color()) for ax in fig.axes for line in ax.get_lines()}
    codes = np.unique(ds["outcome"].values)
    assert {to_rgba(P.OUTCOME_PALETTE.colour(c)) for c in codes} <= drawn
    assert set(P.legend_texts(fig)) >= {P.OUTCOME_PALETTE.label(c) for c in codes}


# ------------------------------------------------------------------ fig11-13
def test_outcome_legend_equals_the_categories_drawn(fig12):
    fig = _rendered(get("fig12").plot(fig12))
    texts = P.legend_texts(fig)
    codes = np.unique(fig12["outcome"].values)
    outcome_texts = {P.OUTCOME_PALETTE.label(c) for c in P.OUTCOME_PALETTE.codes}
    assert {t for t in texts if t in outcome_texts} == {P.OUTCOME_PALETTE.label(c) for c in codes}
    drawn = {c.get_label(): c for ax in fig.axes for c in ax.collections
             if isinstance(c, LineCollection) and (c.get_gid() or "").startswith("boundary_")}
    kinds = set(np.unique(fig12["boundary_type"].values)) - {boundaries.NOT_BOUNDARY}
    assert kinds, "the quick fig12 grid has typed boundaries"
    from rimroll.workflows.outcome_grids import BOUNDARY_STYLES

    boundary_texts = {s["label"] for s in BOUNDARY_STYLES.values()}
    assert {t for t in texts if t in boundary_texts} == set(drawn)
    # the legend draws each boundary exactly as the plot does
    handles = {h.get_label(): h for leg in fig.legends for h in leg.legend_handles}
    for label, coll in drawn.items():
        assert to_rgba(handles[label].get_color()) == tuple(coll.get_color()[0])
        assert handles[label].get_linewidth() == pytest.approx(coll.get_linewidth()[0])


def test_undetermined_boundary_cells_are_drawn_and_named(fig12):
    from rimroll.workflows.outcome_grids import BOUNDARY_STYLES

    lab = fig12["boundary_type"].values
    if not (lab == boundaries.UNDETERMINED).any():
        pytest.skip("no undetermined cell on this grid")
    fig = get("fig12").plot(fig12)
    assert BOUNDARY_STYLES[boundaries.UNDETERMINED]["label"] in P.legend_texts(fig)


def test_boundary_lines_run_between_periodic_and_other_cells():
    from rimroll.workflows.outcome_grids import boundary_segments

    w1, beta = np.arange(4.0), np.arange(3.0)
    periodic = np.zeros((3, 4), bool)
    periodic[1, 1] = True
    labels = np.zeros((3, 4), np.int8)
    labels[1, 1] = labels[1, 2] = labels[0, 1] = boundaries.DEADLOCK
    segs = boundary_segments(labels, periodic, w1, beta, boundaries.DEADLOCK)
    assert sorted(map(tuple, map(tuple, segs))) == sorted([((1.5, 0.5), (1.5, 1.5)), ((0.5, 0.5), (1.5, 0.5))])


def test_contour_labels_clear_of_the_star_and_of_each_other(fig12):
    fig = _rendered(get("fig12").plot(fig12))
    renderer = fig.canvas.get_renderer()
    checked = 0
    for ax in [a for panel in fig.axes for a in (panel, *panel.child_axes)]:  # zoom insets too
        stars = [line for line in ax.get_lines() if line.get_marker() == "*"]
        labels = [t for t in ax.texts if t.get_text().endswith(" s")]
        if not stars or not labels:
            continue
        star = ax.transData.transform(np.column_stack(stars[0].get_data()))[0]
        boxes = [t.get_window_extent(renderer) for t in labels]
        for box in boxes:
            assert not box.expanded(1.0, 1.0).padded(4).contains(*star)
        for i in range(len(boxes)):
            for j in range(i + 1, len(boxes)):
                assert not boxes[i].overlaps(boxes[j])
        checked += 1
    assert checked, "no dissipative panel with time contours on the quick fig12 grid"


def test_outcome_plot_reads_string_scene_labels(fig12):
    ds = fig12.assign_coords(scene=list(P.SCENE_KEYS))
    fig = get("fig12").plot(ds)
    titles = [ax.get_title() for ax in fig.axes]
    assert titles[0].startswith("rolling only") and titles[2].startswith("slipping + drilling resistance")
    assert [P.scene_key(v) for v in fig12["scene"].values] == list(P.SCENE_KEYS)


# ------------------------------------------------------------------ steady maps and cubes
def test_fig8_one_label_per_region_and_sign(tmp_path):
    ds = _run(tmp_path, "fig8", "mu=inf", "v_throw=7")
    fig = get("fig8").plot(ds)
    texts = [t.get_text() for t in fig.axes[0].texts]
    region_texts = [t for t in texts if len(t) == 2 and t[0] in "ABC"]
    assert region_texts and len(region_texts) == len(set(region_texts))
    assert all(t[1] in "+\u2212" for t in region_texts)


def test_restricted_grids_show_the_computed_domain_only(tmp_path):
    ds = _run(tmp_path, "fig8", "beta0=0:1.5:50")
    ax = get("fig8").plot(ds).axes[0]
    assert ax.get_xlim() == pytest.approx((0.0, 1.5))
    assert ax.get_ylim() == pytest.approx((float(ds["omega30"].min()), float(ds["omega30"].max())))
    ds9 = _run(tmp_path, "fig9", "rho_over_R=0.3,0.5")
    ax = get("fig9").plot(ds9).axes[0]
    assert ax.get_xlim() == pytest.approx((0.3, 0.5))
    assert ax.get_ylim() == pytest.approx((float(ds9["j"].min()), float(ds9["j"].max())))


def test_fig7_legend_names_every_speed_drawn(tmp_path):
    ds = _run(tmp_path, "fig7")
    fig = _rendered(get("fig7").plot(ds))
    ax = fig.axes[0]
    assert {"1 m/s", "3 m/s", "5 m/s", "7 m/s", "10 m/s"} <= set(P.legend_texts(fig))
    box = ax.get_window_extent()
    for t in ax.texts:  # every label fully inside the axes (none clipped at an edge)
        ext = t.get_window_extent(fig.canvas.get_renderer())
        assert box.x0 <= ext.x0 and ext.x1 <= box.x1 and box.y0 <= ext.y0 and ext.y1 <= box.y1


def test_invariants_and_solution_types_speak_plainly(tmp_path):
    inv = _run(tmp_path, "invariants")
    texts = P.legend_texts(get("invariants").plot(inv))
    assert texts and not any("trajectory" in t for t in texts)
    b0 = inv["beta_t"].isel(t=0).values
    assert all(any(f"{b:.3f}" in t for t in texts) for b in b0)
    types = _run(tmp_path, "solution-types")
    ax = get("solution-types").plot(types).axes[0]
    assert ax.get_xlim() == (0.0, 1.0)
    assert "subset" not in ax.get_title() and "seed 0" in ax.get_title()


def test_realisable_cube_mu_in_order_and_select(tmp_path):
    ds = _run(tmp_path, "realisable-cube", "mu=2,1,0.5", "v_throw=3,7", "j=0.5,0.6667", "rho_over_R=0.5778",
              "n_beta0=24", "n_omega30=16")
    fig = get("realisable-cube").plot(ds)
    lines = fig.axes[0].get_lines()
    mus = [float(line.get_label().split("=")[1]) for line in lines]
    assert mus == sorted(mus)  # drawn and listed in order of mu
    lum = [np.dot(to_rgba(line.get_color())[:3], (0.299, 0.587, 0.114)) for line in lines]
    assert lum == sorted(lum)  # a sequential colormap: lightness grows with mu
    assert fig.axes[0].get_legend() is not None
    nc = tmp_path / "realisable-cube.nc"
    assert main(["plot", str(nc), "--select", "j=0.5"]) == 0
    assert (tmp_path / "realisable-cube_j=0.5.png").is_file()


def test_select_names_a_bad_dimension(tmp_path, capsys):
    _run(tmp_path, "fig9")
    assert main(["plot", str(tmp_path / "fig9.nc"), "--select", "j=0.5"]) == 2  # a grid axis, not a cube's
    err = capsys.readouterr().err.strip()
    assert err.startswith("study: error: --select") and "not a cube" in err and "\n" not in err
    _run(tmp_path, "realisable-cube", "n_beta0=12", "n_omega30=8")
    assert main(["plot", str(tmp_path / "realisable-cube.nc"), "--select", "beta0=1"]) == 2
    err = capsys.readouterr().err.strip()
    assert "rho_over_R" in err and "\n" not in err


def test_a_small_periodic_region_gets_a_zoom_that_shows_it(fig12):
    from rimroll.workflows.outcome_grids import _small_region

    mask = np.zeros((240, 360), bool)
    mask[120:124, 170:180] = True
    rows, cols = _small_region(mask)
    assert mask[rows, cols].sum() == mask.sum()  # the zoom holds the whole region, with a margin
    assert rows.stop - rows.start < 20 and cols.stop - cols.start < 40
    big = np.zeros((240, 360), bool)
    big[50:150, 100:250] = True
    assert _small_region(big) is None
    # on the quick fig12 grid, the slipping scene's periodic island is a few cells: it is zoomed
    fig = get("fig12").plot(fig12)
    periodic = fig12["outcome"].isel(scene=1).transpose("beta", "omega1").values == 2
    if _small_region(periodic) is not None:
        assert fig.axes[1].child_axes


def test_cells_on_the_rim_are_marked_above_the_cells_and_both_islands_outlined(fig12):
    """Cells still on the rim at t_max lie along the boundary lines, which hid their grey: each is
    marked (one marker per on_rim_reason, in the legend); the dissipative panels outline the
    periodic islands of both conservative scenes, each named in the legend."""
    from rimroll.workflows.outcome_grids import ISLAND_STYLES, ON_RIM_MARKERS

    ds = fig12.copy(deep=True)
    cells = [(5, 10), (6, 11), (7, 12)]
    for i, j in cells:
        ds["outcome"].values[1, i, j] = solver.engine.outcomes.ON_RIM_AT_T_MAX
        ds["on_rim_reason"].values[1, i, j] = solver.engine.outcomes.SLIP_ROLL_CYCLING
    fig = _rendered(get("fig12").plot(ds))
    gid = f"on_rim_{solver.engine.outcomes.SLIP_ROLL_CYCLING}"
    marks = [line for line in fig.axes[1].get_lines() if line.get_gid() == gid]
    assert len(marks) == 1
    x, y = marks[0].get_data()
    assert sorted(zip(np.round(y, 9), np.round(x, 9))) == sorted(
        (round(float(ds["beta"][i]), 9), round(float(ds["omega1"][j]), 9)) for i, j in cells)
    texts = P.legend_texts(fig)
    assert ON_RIM_MARKERS[solver.engine.outcomes.SLIP_ROLL_CYCLING]["label"] in texts
    flags = ds["former_periodic"].values[0]
    assert (flags & 1).any() and (flags & 2).any()
    assert {ISLAND_STYLES["rolling_only"]["label"], ISLAND_STYLES["slipping"]["label"]} <= set(texts)
