"""Figures a reader can trust: properties of the drawn figures, not their pixels.

Legend entries equal the categories drawn, axis limits equal the computed domain, one outcome
palette for every outcome figure, contour labels clear of the steady-motion star and of each
other, one label per realisable region and sign.
"""

from __future__ import annotations

import pathlib
import re

import numpy as np
import pytest
import xarray as xr
from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.collections import LineCollection
from matplotlib.colors import to_rgba

from rimroll import solver
from rimroll.solver.analysis import boundaries
from rimroll.solver.engine import outcomes
from rimroll.study import cubeplots as C
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


def _axes_of(fig) -> list:
    """The visible axes of a figure, its subfigures' and their insets."""
    found = [a for a in fig.get_children() if hasattr(a, "get_xlabel")]
    for sub in getattr(fig, "subfigs", []):
        found += _axes_of(sub)
    found += [c for a in list(found) for c in a.child_axes]
    return [a for a in found if a.get_visible()]


def _texts(fig) -> list:
    """Every visible, non-empty text of a drawn figure: suptitles, titles, axis labels, the tick
    labels in view, texts, annotations and contour labels of every axes (insets and subfigures
    included), legend entries."""
    figs = [fig, *getattr(fig, "subfigs", [])]
    out = [f._suptitle for f in figs if f._suptitle is not None] + [t for f in figs for t in f.texts]
    out += [t for f in figs for leg in f.legends for t in leg.get_texts()]
    for ax in _axes_of(fig):
        out += [ax.title, ax._left_title, ax._right_title, ax.xaxis.label, ax.yaxis.label, *ax.texts]
        for axis, limits in ((ax.xaxis, ax.get_xlim()), (ax.yaxis, ax.get_ylim())):
            scale = axis.get_transform()  # the tick labels drawn are those of ticks within the limits
            lo, hi = sorted(np.ravel(scale.transform(np.reshape(limits, (-1, 1)))))
            for loc, label in zip(axis.get_ticklocs(), axis.get_ticklabels()):
                v = float(np.ravel(scale.transform([[loc]]))[0])
                if lo - 1e-9 * (hi - lo) <= v <= hi + 1e-9 * (hi - lo):
                    out.append(label)
        if ax.get_legend() is not None:
            out += list(ax.get_legend().get_texts())
    unique = {id(t): t for t in out}  # a suptitle is also among the figure's texts
    return [t for t in unique.values() if t.get_visible() and t.get_text().strip()]


def _overlaps(fig) -> list:
    """Pairs of texts of ``fig`` whose drawn bounding boxes overlap (by more than a pixel)."""
    renderer = fig.canvas.get_renderer()
    boxes = [(t, t.get_window_extent(renderer)) for t in _texts(fig)]
    boxes = [(t, b) for t, b in boxes if b.width > 0 and b.height > 0]
    bad = []
    for i, (t, a) in enumerate(boxes):
        for u, b in boxes[i + 1:]:
            if a.x0 + 1 < b.x1 and b.x0 + 1 < a.x1 and a.y0 + 1 < b.y1 and b.y0 + 1 < a.y1:
                bad.append((t.get_text(), u.get_text()))
    return bad


def _cut_off(fig) -> list:
    """Texts of ``fig`` drawn partly outside the figure (by more than a pixel): a title too long for it."""
    renderer = fig.canvas.get_renderer()
    page = fig.bbox
    return [t.get_text() for t in _texts(fig) for b in [t.get_window_extent(renderer)]
            if b.width > 0 and (b.x0 < page.x0 - 1 or b.x1 > page.x1 + 1 or b.y0 < page.y0 - 1 or b.y1 > page.y1 + 1)]


UNITS = re.compile(r"\[[^\]]+\]")


def _labels_without_units(fig) -> list:
    """x and y labels of the figure's data axes (colorbars aside) that give no units in brackets."""
    out = []
    for ax in _axes_of(fig):
        if hasattr(ax, "_colorbar"):
            continue
        out += [label for label in (ax.get_xlabel(), ax.get_ylabel()) if label.strip() and not UNITS.search(label)]
    return out


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


def test_boundary_lines_are_polylines_through_the_cell_edge_midpoints(fig12):
    """The plot draws the boundary curves (study.curve_variables), not the staircase of cell edges: each
    segment joins two points half a cell or less apart, and a corner is cut diagonally."""
    fig = get("fig12").plot(fig12)
    segs = [seg for c in fig.axes[0].collections if (c.get_gid() or "").startswith("boundary_")
            for seg in c.get_segments()]
    assert segs
    step = np.array([np.diff(fig12["omega1"].values[:2])[0], np.diff(fig12["beta"].values[:2])[0]])
    moves = np.concatenate([np.abs(np.diff(s, axis=0)) / step for s in segs])
    assert moves.max() <= 1.0 + 1e-9
    assert ((moves[:, 0] > 0) & (moves[:, 1] > 0)).any()  # diagonal moves: no staircase


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
@pytest.mark.parametrize("sets", [(), ("mu=inf", "v_throw=7")])
def test_fig8_labels_every_piece_of_each_region_and_sign(tmp_path, sets):
    """Each (region, sign of omega20) that occurs has a label pointing into a cell of its own; region
    A holds both signs (paper Sect. 3), and A's other-sign sliver is labelled too."""
    ds = _run(tmp_path, "fig8", *sets)
    fig = _rendered(get("fig8").plot(ds))
    ax = fig.axes[0]
    region = ds["region"].transpose("omega30", "beta0").values
    sign = np.sign(ds["omega20"].transpose("omega30", "beta0").values)
    letters = {"A": 1, "B": 2, "C": 3}
    labelled = set()
    for t in ax.texts:
        text = t.get_text()
        if len(text) != 2 or text[0] not in letters:
            continue
        x, y = t.xy if hasattr(t, "xy") else t.get_position()  # an annotation points into its piece
        i = int(np.argmin(np.abs(ds["omega30"].values - y)))
        j = int(np.argmin(np.abs(ds["beta0"].values - x)))
        want = (letters[text[0]], 1 if text[1] == "+" else -1)
        near = [(region[a, b], sign[a, b]) for a in range(max(i - 1, 0), i + 2) for b in range(max(j - 1, 0), j + 2)
                if a < region.shape[0] and b < region.shape[1]]
        assert want in near, (text, x, y)
        labelled.add(text)
    occurring = {f"{k}{'+' if s > 0 else chr(0x2212)}" for k, code in letters.items() for s in (1, -1)
                 if ((region == code) & (sign == s)).any()}
    assert labelled == occurring
    assert {"A+", "A\u2212"} <= labelled
    assert not _overlaps(fig)


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
    fig = get("solution-types").plot(types)
    title = fig._suptitle.get_text()
    assert fig.axes[0].get_xlim() == (0.0, 1.0)
    assert "subset" not in title and "seed 0" in title


def test_realisable_cube_shows_every_swept_axis_and_a_slice_as_fig8(tmp_path):
    ds = _run(tmp_path, "realisable-cube", "mu=2,1,0.5", "v_throw=3,7", "j=0.5,0.6667", "rho_over_R=0.5778",
              "n_beta0=24", "n_omega30=16")
    fig = get("realisable-cube").plot(ds)
    xlabels = {ax.get_xlabel() for ax in fig.axes}
    assert {C.axis_label(ds, d) for d in ("mu", "v_throw", "j")} <= xlabels  # every swept axis has a panel
    assert {"region A", "region B", "region C"} <= set(P.legend_texts(fig))
    (panel,) = [ax for ax in fig.axes if ax.get_xlabel() == C.axis_label(ds, "mu")]
    ticks = sorted(zip(panel.get_xticks(), (t.get_text() for t in panel.get_xticklabels())))
    assert [t for _, t in ticks] == ["0.5", "1", "2"]  # swept as 2, 1, 0.5: drawn in order of mu
    nc = tmp_path / "realisable-cube.nc"
    assert main(["plot", str(nc), "--select", "j=0.5"]) == 0
    assert (tmp_path / "realisable-cube_j=0.5.png").is_file()
    # held on every swept axis: one section, drawn as Fig. 8 (regions over (beta0, omega30), labelled)
    assert main(["plot", str(nc), "--select", "mu=1,v_throw=7,j=0.6667"]) == 0
    one = C.select(ds, {"mu": 1.0, "v_throw": 7.0, "j": 0.6667})
    fig = _rendered(get("realisable-cube").plot(one))
    (ax,) = fig.axes
    assert ax.get_xlabel() == r"height angle $\beta_0$ [rad]" and "omega" in ax.get_ylabel().lower()
    assert any(t.get_text() in ("A+", "A\u2212") for t in ax.texts)


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


# ------------------------------------------------------------------ what can be checked without eyes
@pytest.fixture(scope="module")
def sweep(tmp_path_factory):
    """The README's first-hour sweep: outcomes over mu at k_r = k_d = 0, omega2 = 65 1/s."""
    return _run(tmp_path_factory.mktemp("sweep"), "outcome-cube", "mu=0.25,0.5,1,2", "k_r=0", "k_d=0", "omega2=65")


def test_the_first_hour_sweep_shows_mu(sweep):
    """Against mu, not k_r and k_d (which the sweep holds at 0): one curve per outcome over the four
    values of mu, and the outcome map of each value below."""
    fig = _rendered(get("outcome-cube").plot(sweep))
    (panel,) = [ax for ax in fig.axes if ax.get_xlabel() == C.axis_label(sweep, "mu")]
    assert [t.get_text() for t in panel.get_xticklabels()] == ["0.25", "0.5", "1", "2"]
    lines = [line for line in panel.get_lines() if len(line.get_xdata()) == 4]
    codes = np.unique(sweep["outcome"].values)
    assert len(lines) == codes.size
    for line in lines:
        np.testing.assert_array_equal(line.get_xdata(), [0.25, 0.5, 1.0, 2.0])
    maps = [ax for ax in fig.axes if "omega_1" in ax.get_xlabel()]
    assert sorted(ax.get_title() for ax in maps) == sorted(C.quantity_text(sweep, "mu", m) for m in (0.25, 0.5, 1, 2))
    assert "k_r" in fig.texts[0].get_text() if fig.texts else "k_r" in fig._suptitle.get_text()
    assert not _labels_without_units(fig) and not _overlaps(fig) and not _cut_off(fig)


def test_a_cube_slice_is_drawn_as_its_section_map(sweep, tmp_path):
    """study plot --select of every swept axis: the outcome map over (omega1, beta) as in Figs. 11-13."""
    one = C.select(sweep, {"mu": 1.0})
    fig = _rendered(get("outcome-cube").plot(one))
    (ax,) = fig.axes
    assert "omega_1" in ax.get_xlabel() and "beta" in ax.get_ylabel()
    (mesh,) = [c for c in ax.collections if c.__class__.__name__ == "QuadMesh"]
    assert mesh.get_array().shape == (sweep.sizes["beta"], sweep.sizes["omega1"])
    assert any(line.get_marker() == "*" for line in ax.get_lines())  # the steady motion
    assert not _labels_without_units(fig) and not _overlaps(fig)


def test_a_swept_mu_may_hold_inf(tmp_path, capsys):
    """Rolling only and slipping on one axis; inf is allowed for mu only (the setting table's rule)."""
    from rimroll.study.setting_table import SWEEP_KEYS, lookup

    ds = _run(tmp_path, "outcome-cube", "mu=1,inf", "k_r=0", "k_d=0", "omega2=65,105", "n_beta=6", "n_omega1=6")
    assert ds["mu"].values.tolist() == [1.0, np.inf]
    alone = _run(tmp_path / "alone", "outcome-cube", "mu=inf", "k_r=0", "k_d=0", "omega2=65,105", "n_beta=6",
                 "n_omega1=6")
    np.testing.assert_array_equal(ds["outcome"].sel(mu=np.inf).values, alone["outcome"].values)
    fig = _rendered(get("outcome-cube").plot(ds))
    (panel,) = [ax for ax in fig.axes if ax.get_xlabel() == C.axis_label(ds, "mu")]
    assert [t.get_text() for t in panel.get_xticklabels()] == ["1", "\u221e"]
    assert C.axis_label(ds, "omega2") in {ax.get_xlabel() for ax in fig.axes}  # every swept axis
    assert main(["plot", str(tmp_path / "outcome-cube.nc"), "--select", "mu=inf,omega2=65"]) == 0
    assert (tmp_path / "outcome-cube_mu=inf_omega2=65.png").is_file()
    assert [k for k in SWEEP_KEYS if lookup(k).range is not None and lookup(k).range.contains(np.inf)] == ["mu"]
    assert "inf" in lookup("mu").doc and "only setting that takes inf" in lookup("mu").doc
    assert main(["run", "realisable-cube", "--quick", "--set", "j=0.5,inf", "--out", str(tmp_path)]) == 2
    assert "j" in capsys.readouterr().err


def test_select_takes_several_pairs_in_one_word(tmp_path):
    from rimroll.study import cli_text

    assert cli_text.split("j=0.5,mu=1", "--select") == [("j", "0.5"), ("mu", "1")]
    _run(tmp_path, "realisable-cube", "mu=0.5,1", "v_throw=3,7", "j=0.5,0.6667", "n_beta0=24", "n_omega30=16")
    assert main(["plot", str(tmp_path / "realisable-cube.nc"), "--select", "j=0.5,mu=1"]) == 0
    assert (tmp_path / "realisable-cube_j=0.5_mu=1.png").is_file()


def test_select_refuses_a_value_outside_the_axis(tmp_path, capsys):
    """Nearest grid value on the axis; far outside it (mu=99 of mu = 0.5, 1) names no slice: one line."""
    _run(tmp_path, "realisable-cube", "mu=0.5,1", "v_throw=3,7", "n_beta0=24", "n_omega30=16")
    nc = str(tmp_path / "realisable-cube.nc")
    capsys.readouterr()
    assert main(["plot", nc, "--select", "mu=99"]) == 2
    err = capsys.readouterr().err
    assert err.startswith("study: error: --select mu=99: outside the file's mu axis (0.5, 1)") and err.count("\n") == 1
    assert main(["plot", nc, "--select", "mu=0.8,v_throw=3.2"]) == 0  # on the axes: the nearest values
    capsys.readouterr()
    assert main(["plot", nc, "--select", "mu=1", "--select", "mu=0.5"]) == 2  # the last one won silently
    assert "--select mu is given twice" in capsys.readouterr().err
    assert main(["plot", nc, "--select", "mu=0\uff15"]) == 2  # a full-width digit: not a number


@pytest.mark.parametrize("name, sets", [
    ("fig7", ()), ("fig8", ()), ("fig9", ()), ("fig13", ()),
    ("realisable-cube", ("n_beta0=24", "n_omega30=16")),
    ("solution-types", ("n_samples=8",)), ("invariants", ("n_time=21",)),
    ("predictability", ("omega2=65", "n_sample=20")),
    ("make-probability", ("n_beta=6", "n_omega1=8", "n_samples=4", "sigma=0.5,1", "mu=1,inf")),
    pytest.param("work-precision", ("n_states=16", "n_scipy=2", "n_scipy_hybrid=1", "n_rtol=2", "rtol_max=1e-6"),
                 marks=pytest.mark.slow),  # ~50 s: scipy at rtol 1e-6 in every scene
    ("continuation", ("n_beta=6", "n_omega1=8")),
])
def test_figures_label_their_axes_with_units_and_no_text_covers_another(tmp_path, name, sets):
    """Every data axis says its units; every swept axis of a cube has a panel; no two texts (titles,
    labels, tick labels, region and contour labels, legend entries, inset labels) overlap on the
    drawn figure."""
    ds = _run(tmp_path, name, *sets)
    fig = _rendered(get(name).plot(ds))
    assert not _labels_without_units(fig), name
    assert not _overlaps(fig), name
    assert not _cut_off(fig), name
    xlabels = {ax.get_xlabel() for ax in _axes_of(fig)}
    assert all(C.axis_label(ds, d) in xlabels for d in C.swept(ds)), (name, C.swept(ds), xlabels)


def test_rim_states_keeps_its_three_titles_inside_the_figure(tmp_path):
    """The third panel's title ran past the figure's right edge; no text is cut off or covers another (its
    swept axes are pooled into the panels, so the cube test above does not apply)."""
    ds = _run(tmp_path, "rim-states", "n_dv=5", "n_angle=5", "n_azimuth=3")
    fig = _rendered(get("rim-states").plot(ds))
    assert not _cut_off(fig) and not _overlaps(fig) and not _labels_without_units(fig)
    assert all(ax.get_title() for ax in _axes_of(fig)[:3])


def test_fig12_texts_and_labels(fig12):
    fig = _rendered(get("fig12").plot(fig12))
    assert not _labels_without_units(fig) and not _overlaps(fig)


def test_fig9_shading_reaches_the_axes(tmp_path):
    """The grid's cells start at rho/R = 0.012, j = 0.02: the stable shading is carried to 0."""
    ds = _run(tmp_path, "fig9")
    ax = get("fig9").plot(ds).axes[0]
    fill = [c for c in ax.collections if getattr(c, "filled", False)][0]
    vertices = np.concatenate([p.vertices for p in fill.get_paths() if len(p.vertices)])
    assert vertices[:, 0].min() == pytest.approx(0.0) and vertices[:, 1].min() == pytest.approx(0.0)
    ball = [line for line in ax.get_lines() if line.get_marker() == "o" and line.get_markerfacecolor() != "none"]
    assert ball and all(line.get_zorder() > 3 for line in ball)  # above the hatching (zorder 3)


def test_fig12_separatrix_then_deadlock_is_drawn_unlike_a_deadlock(fig12):
    from rimroll.study import curve_variables as curves
    from rimroll.workflows.outcome_grids import BOUNDARY_STYLES

    ds = fig12.copy(deep=True)
    lab = ds["boundary_type"].values
    periodic = ds["outcome"].values == 2
    edge = np.argwhere(periodic[0] & ~np.roll(periodic[0], 1, axis=0))  # periodic cells with a non-periodic one below
    i, j = edge[0]
    lab[0, i, j] = lab[0, i - 1, j] = boundaries.SEPARATRIX_AND_DEADLOCK
    ds = ds.drop_vars(curves.NAMES)  # the plot traces them anew from the changed types
    fig = _rendered(get("fig12").plot(ds))
    colls = {c.get_gid(): c for c in fig.axes[0].collections if (c.get_gid() or "").startswith("boundary_")}
    both = colls[f"boundary_{boundaries.SEPARATRIX_AND_DEADLOCK}"]
    offset, dashes = both.get_linestyle()[0]
    assert dashes is not None  # dashed ...
    assert to_rgba(both.get_gapcolor()[0]) == to_rgba(BOUNDARY_STYLES[boundaries.SEPARATRIX_AND_DEADLOCK]["gapcolor"])
    if f"boundary_{boundaries.DEADLOCK}" in colls:  # ... where a deadlock is a solid line
        assert colls[f"boundary_{boundaries.DEADLOCK}"].get_linestyle()[0][1] is None


def test_dissipative_panels_dot_a_long_time_on_the_rim_and_dash_the_islands(fig12):
    from rimroll.workflows.outcome_grids import ISLAND_STYLES

    assert all(style["ls"] not in (":", "dotted") for style in ISLAND_STYLES.values())
    fig = get("fig12").plot(fig12)
    long = fig12["t_end"].isel(scene=3).values >= P.LONG_TIME
    hatched = [c for c in fig.axes[3].collections if ".." in (getattr(c, "hatches", None) or ())]
    assert bool(hatched) == bool(long.any())
    assert any(f"{P.LONG_TIME:g} s or longer" in t for t in P.legend_texts(fig)) == bool(long.any())


def test_zoom_insets_label_their_axes_with_units(tmp_path):
    fig = _rendered(get("fig13").plot(_run(tmp_path, "fig13")))
    insets = [c for ax in fig.axes for c in ax.child_axes]
    assert insets
    for inset in insets:
        assert UNITS.search(inset.get_xlabel()) and UNITS.search(inset.get_ylabel())


def test_xarray_plot_of_a_section_keeps_its_axis_labels_on_the_figure(fig12):
    """Coordinates' long_names are short enough for xarray's own plot (it wraps at 30 characters)."""
    import matplotlib.pyplot as plt

    fig = plt.figure()
    try:
        fig12["outcome"].sel(scene="slipping").plot()
        fig.canvas.draw()
        ax = fig.axes[0]
        inside = fig.bbox
        for label in (ax.xaxis.label, ax.yaxis.label):
            box = label.get_window_extent()
            assert "\n" not in label.get_text(), label.get_text()
            assert inside.x0 <= box.x0 and box.x1 <= inside.x1 and inside.y0 <= box.y0 and box.y1 <= inside.y1
    finally:
        plt.close(fig)


def test_axis_labels_fit_one_line_of_xarrays_plots():
    """xarray labels a plot's axis with long_name and units, wrapped at 30 characters: every numeric
    grid axis of every study, and every swept setting the study layer declares, fits one line (the
    detail is in the coordinate's comment). The physical parameters' long_names are solver's."""
    from rimroll.study import registry
    from rimroll.study.plan import make_plan

    for name in registry.names():
        for axis in make_plan(registry.get(name), quick=True).grid:
            if not axis.categorical:
                assert len(f"{axis.long_name} [{axis.units}]") <= 30, (name, axis.name, axis.long_name)
    from rimroll.study.setting_table import SWEEP_KEYS, TABLE

    for key in SWEEP_KEYS:
        if not TABLE[key].physical:
            assert len(f"{TABLE[key].axis_long_name} [{TABLE[key].units}]") <= 30, key


# ---------------------------------------------------------------- cubes of every shape, small fractions
_SLICES = pathlib.Path(C.__file__).with_name("reference_slices") / "quick"


def _outcome_cube(shape: dict) -> xr.Dataset:
    """A cube of the outcome-cube study's quick reference slice with the swept axes ``shape`` ({axis: values});
    the other axes held at their first value. Values beyond the slice's repeat its maps (the figure is tested,
    not the physics)."""
    ds = xr.open_dataset(_SLICES / "outcome-cube.nc").load()
    ds = ds.isel({d: 0 for d in ("mu", "k_r", "k_d", "omega2") if d not in shape})
    for d, n in shape.items():
        picked = xr.concat([ds.isel({d: [i % ds.sizes[d]]}) for i in range(n)], d)
        values = np.linspace(0.1, 1.8, n) if d == "mu" else np.linspace(0.0, 0.05 * n, n)
        ds = picked.assign_coords({d: (d, values, ds[d].attrs)})
    ds.attrs["swept"] = " ".join(shape)
    return ds


def _titles_and_legends(fig) -> list:
    """The titles, legends and axis labels of a figure, its subfigures' and its visible axes'."""
    found = [t for t in (fig._suptitle, *fig.legends) if t is not None]
    for sub in getattr(fig, "subfigs", []):
        found += _titles_and_legends(sub)
    for ax in fig.get_children():
        if hasattr(ax, "get_xlabel") and ax.get_visible():
            found += [a for a in (ax.title, ax.xaxis.label, ax.yaxis.label, ax.get_legend()) if a is not None]
    return found


def _outside(fig) -> list[str]:
    """The titles, legends and axis labels of a drawn figure that reach beyond its edges (by more than a pixel)."""
    from matplotlib.text import Text

    renderer = fig.canvas.get_renderer()
    box = fig.bbox
    out = []
    for artist in _titles_and_legends(fig):
        if not artist.get_visible() or (isinstance(artist, Text) and not artist.get_text().strip()):
            continue
        ext = artist.get_window_extent(renderer)
        if ext.x0 < box.x0 - 1 or ext.y0 < box.y0 - 1 or ext.x1 > box.x1 + 1 or ext.y1 > box.y1 + 1:
            out.append(artist.get_text() if isinstance(artist, Text) else "a legend")
    return out


@pytest.mark.parametrize("shape", [{"mu": 2}, {"mu": 18}, {"mu": 3, "k_r": 2},  # maps below, none, six maps
                                   {"mu": 2, "k_r": 2, "k_d": 2, "omega2": 2}])
def test_every_cube_shape_keeps_its_title_and_legend_inside_the_figure(shape):
    """One swept axis of 18 values drew 4.5 in wide, its title and legend clipped at both sides."""
    fig = _rendered(get("outcome-cube").plot(_outcome_cube(shape)))
    assert _outside(fig) == []


def test_a_parameter_without_effect_is_not_in_a_title():
    """C_D acts only with air (rho_air > 0): a title that lists it at rho_air = 0 names a switched-off term."""
    ds = _outcome_cube({"mu": 2})
    ds.attrs.update(param_rho_air=0.0, param_C_D=0.5)
    title = get("outcome-cube").plot(ds)._suptitle.get_text()
    assert "C_D" not in title and r"\rho_{air}$ = 0" in title
    ds.attrs.update(param_rho_air=1.2)
    assert "$C_D$ = 0.5" in get("outcome-cube").plot(ds)._suptitle.get_text()


def _span_px(ax, line) -> float:
    """The height [px] that a drawn line's values cover on its axes."""
    y = np.asarray(line.get_ydata(), dtype=float)
    pts = ax.transData.transform(np.column_stack([np.zeros(y.size), y]))
    return float(np.ptp(pts[:, 1]))


def test_a_small_fraction_shows_its_changes_beside_large_ones():
    """The periodic fraction (0.016-0.049) beside falls out (0.55-0.74) in the continuation figure, and the
    periodic fraction of a cube: their changes span at least a tenth of the panel's height (on one linear axis
    with 0.7 they spanned 3 %)."""
    ds = xr.open_dataset(_SLICES / "continuation.nc").load()
    fig = _rendered(get("continuation").plot(ds))
    ax = fig.axes[0]
    name = P.OUTCOME_PALETTE.label(outcomes.PERIODIC_ROLLING)
    periodic = next(line for line in ax.get_lines() if line.get_label() == name)
    assert np.ptp(periodic.get_ydata()) < 0.05  # a small fraction that changes
    assert _span_px(ax, periodic) > 0.1 * ax.bbox.height
    cube = _rendered(get("outcome-cube").plot(_outcome_cube({"mu": 2, "k_r": 2})))
    panel = cube.axes[0]
    small = next(line for line in panel.get_lines() if line.get_label() == name)
    assert np.ptp(small.get_ydata()) > 0 and _span_px(panel, small) > 0.1 * panel.bbox.height


def test_the_legend_draws_the_time_on_the_rim_white_as_its_lines():
    """The contours are white: their legend entry is a white line (outlined, to show on white), not grey."""
    from matplotlib.figure import Figure

    ax = Figure().add_subplot()
    w1, beta = np.linspace(-5, 5, 20), np.linspace(0.5, 1.5, 15)
    t_end = np.add.outer(beta * 10, 2.5 * np.abs(w1))  # 5 .. 27.5 s over the map
    handle = P.time_on_rim(ax, w1, beta, t_end, 30.0, labels=False)["time"]
    assert to_rgba(handle.get_color()) == to_rgba(P.TIME_STYLE["colors"]) == to_rgba("white")
    assert handle.get_path_effects()  # outlined
