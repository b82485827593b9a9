"""The ``shot`` study: its --quick file (CF attributes, outcomes equal to direct ``simulate_shots``
calls), its settings' checks (one line, exit 2) and its figure (categories with a legend, texts
inside the figure)."""

from __future__ import annotations

import numpy as np
import pytest
import xarray as xr
from matplotlib.backends.backend_agg import FigureCanvasAgg

shots = pytest.importorskip("rimroll.solver.shots", reason="the solver's shot model is not installed")

from rimroll.solver import Params  # noqa: E402
from rimroll.study.cli import main  # noqa: E402
from rimroll.study.registry import get  # noqa: E402


def _run(out, *sets, quick=True):
    args = ["run", "shot", "--out", str(out), "--no-progress", *(["--quick"] if quick else [])]
    for s in sets:
        args += ["--set", s]
    assert main(args) == 0
    return xr.open_dataset(out / "shot.nc")


@pytest.fixture(scope="module")
def quick(tmp_path_factory):
    return _run(tmp_path_factory.mktemp("shot"))


def test_quick_file_has_cf_attributes(quick):
    """Every variable and coordinate has units and long_name; categorical ones flag_values and as
    many flag_meanings; the axes are speed [m s-1] and angle [degree]."""
    assert quick.attrs["Conventions"].startswith("CF-")
    assert quick["speed"].attrs["units"] == "m s-1" and quick["angle"].attrs["units"] == "degree"
    for name in [*quick.data_vars, *quick.coords]:
        attrs = quick[name].attrs
        assert "units" in attrs and attrs.get("long_name"), name
        if "flag_values" in attrs:
            assert len(np.atleast_1d(attrs["flag_values"])) == len(attrs["flag_meanings"].split()), name
    assert quick["outcome"].attrs["flag_meanings"].split() == list(shots.OUTCOME_MEANINGS)
    assert quick["status"].attrs["flag_meanings"].split() == list(shots.STATUS_MEANINGS)
    assert quick.sizes == {"speed": 24, "angle": 20}


def test_quick_outcomes_equal_direct_simulate_shots(quick):
    """The file's outputs at every grid point equal a direct call of ``simulate_shots`` with the
    release converted by hand (degrees to rad) and the study's default contact and ring."""
    speed, angle = np.meshgrid(quick["speed"].values, quick["angle"].values, indexing="ij")
    res = shots.simulate_shots({"speed": speed, "angle": np.radians(angle), "distance": 4.19, "height": 0.92},
                               shots.params_for("paper"), shots.Contact(), geometry="paper")
    for name in ("outcome", "status", "n_impacts", "n_rim_impacts", "n_board_impacts", "first_contact"):
        np.testing.assert_array_equal(quick[name].transpose("speed", "angle").values, res[name], err_msg=name)
    for name in ("t_end", "time_on_rim", "revolutions_on_rim", "beta_cap", "slip_cap"):
        np.testing.assert_allclose(quick[name].transpose("speed", "angle").values, res[name], rtol=1e-12,
                                   equal_nan=True, err_msg=name)
    assert float(quick["ring_R"]) == Params().R and float(quick["ring_a"]) == Params().a


def test_quick_map_holds_a_swish_and_a_make_after_contact(quick):
    """Around a free throw the --quick grid crosses the swish region, the makes after touching the rim
    and the board, and the short misses; a shot that did not finish says why (status), and one whose
    budget ran out is never a make or a miss."""
    names = list(shots.OUTCOME_MEANINGS)
    drawn = {names[c] for c in np.unique(quick["outcome"].values)}
    assert {"swish", "miss_short", "make_board"} <= drawn
    assert drawn & {"make_rim", "make_roll"}
    unfinished = quick["outcome"].values == names.index("unfinished")
    status = quick["status"].values
    budget = np.isin(status, [shots.STATUS_MEANINGS.index(k) for k in ("impact_budget", "time_budget")])
    assert not (budget & ~unfinished).any()  # a spent budget is never a make or a miss
    assert not (unfinished & (status == shots.STATUS_MEANINGS.index("ok"))).any()  # and says why


@pytest.mark.parametrize("item, words", [
    ("e_rim=1.5", "e_rim"), ("mu_rim=-1", "mu_rim"), ("v_cap=-0.1", "v_cap"), ("distance=0", "distance"),
    ("geometry=nba", "geometry"), ("backspin=nan", "backspin"), ("angle_min=95", "angle_min"),
    ("speed_min=8", "speed_max"), ("R=0.3", "geometry"),
])
def test_bad_settings_are_one_line_and_exit_2(tmp_path, capsys, item, words):
    """Every bad setting: exit 2, one line on stderr naming it (the setting table's rule)."""
    code = main(["run", "shot", "--quick", "--out", str(tmp_path), "--no-progress", "--set", item])
    err = capsys.readouterr().err.strip()
    assert code == 2 and "\n" not in err and words in err, err
    assert not (tmp_path / "shot.nc").exists()


def test_figure_legend_is_the_categories_drawn_and_texts_stay_inside(quick):
    """The legend names exactly the outcome groups present in the map (plus the centre line), the
    axes carry units, and every text lies inside the figure."""
    from rimroll.workflows import shot_map as study

    fig = get("shot").plot(quick)
    FigureCanvasAgg(fig).draw()
    ax = fig.axes[0]
    assert "[m/s]" in ax.get_xlabel() and "[degree]" in ax.get_ylabel()
    groups = study.group_codes()[np.unique(quick["outcome"].values)]
    labels = [t.get_text() for leg in fig.legends for t in leg.get_texts()]
    assert labels[:-1] == [study.GROUPS[k][0] for k in sorted(set(groups.tolist()))]
    box = fig.bbox
    texts = [ax.title, ax.xaxis.label, ax.yaxis.label, *[t for leg in fig.legends for t in leg.get_texts()]]
    for t in texts:
        b = t.get_window_extent()
        assert box.x0 <= b.x0 and b.x1 <= box.x1 and box.y0 <= b.y0 and b.y1 <= box.y1, t.get_text()


def test_every_outcome_has_a_group():
    """The figure's categories cover every outcome code of the solver, each once."""
    from rimroll.workflows import shot_map as study

    members = [name for _, _, names in study.GROUPS for name in names]
    assert sorted(members) == sorted(shots.OUTCOME_MEANINGS)
