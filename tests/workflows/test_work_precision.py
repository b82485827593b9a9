"""The work-precision study (docs/work-precision.md): every integrator in every scene, errors
against the rtol-1e-12 reference.

Only accuracy is asserted; timings are figures of the study, never assertions.
"""

import numpy as np
import pytest
import xarray as xr

from rimroll.peer_models import heyoka_rolling
from rimroll.study.outcome_sections import SCENES
from rimroll.workflows.work_precision import INTEGRATORS, REDUCED, speed_ratio

HEYOKA = heyoka_rolling.LABEL


@pytest.fixture(scope="module")
def wp(tmp_path_factory):
    from rimroll.study.cli import main

    out = tmp_path_factory.mktemp("wp")
    args = ["run", "work-precision", "--quick", "--out", str(out), "--no-progress",
            "--set", "n_states=16", "--set", "n_scipy=2", "--set", "n_scipy_hybrid=1",
            "--set", "n_rtol=2", "--set", "rtol_max=1e-6", "--set", "rtol_min=1e-8"]
    assert main(args) == 0
    return xr.open_dataset(out / "work-precision.nc")


def test_every_integrator_runs_in_every_scene_with_units(wp):
    assert list(wp["integrator"].values) == list(INTEGRATORS)
    assert list(wp["scene"].values) == list(SCENES)
    assert wp.sizes == {"scene": 4, "integrator": len(INTEGRATORS), "rtol": 2}
    ours_and_scipy = wp["seconds_per_trajectory"].drop_sel(integrator=[HEYOKA, REDUCED], errors="ignore")
    assert np.isfinite(ours_and_scipy).all()  # scipy too, slipping scenes included
    for name in ("seconds_per_trajectory", "misclassified_fraction", "t_end_error_median", "t_end_error_max"):
        assert wp[name].attrs["units"] and wp[name].attrs["long_name"]


def test_no_method_misclassifies_the_sample_at_these_tolerances(wp):
    assert (wp["misclassified_fraction"].fillna(0) == 0).all()  # (NaN: heyoka in the scenes that slip)


@pytest.mark.skipif(not heyoka_rolling.available(),
                    reason="heyoka is not installed (the optional extra rimroll[bench])")
def test_heyoka_runs_the_rolling_only_scene_and_says_why_not_the_others(wp):
    """With heyoka installed it is one more integrator: the rolling-only scene has its figures, the
    other scenes NaN, and the integrator coordinate says why."""
    hy = wp.sel(integrator=HEYOKA)
    rolling = hy.sel(scene="rolling_only")
    for name in ("seconds_per_trajectory", "seconds_per_trajectory_common", "t_end_error_max", "energy_drift_median"):
        assert np.isfinite(rolling[name]).all(), name
        assert np.isnan(hy[name].sel(scene=[s for s in SCENES if s != "rolling_only"])).all(), name
    assert (rolling["misclassified_fraction"] == 0).all() and (rolling["t_end_error_max"] < 1e-5).all()
    assert (rolling["n_trajectories"] == wp["n_trajectories"].sel(integrator="rimroll_dp5", scene="rolling_only")).all()
    assert "rolling-only scene only" in wp["integrator"].attrs["long_name"]


def test_the_reduced_solver_runs_the_rolling_only_scene_exactly_and_says_why_not_the_others(wp):
    red = wp.sel(integrator=REDUCED)
    rolling = red.sel(scene="rolling_only")
    for name in ("seconds_per_trajectory", "seconds_per_trajectory_common", "t_end_error_max", "energy_drift_median"):
        assert np.isfinite(rolling[name]).all(), name
        assert np.isnan(red[name].sel(scene=[s for s in SCENES if s != "rolling_only"])).all(), name
    assert (rolling["misclassified_fraction"] == 0).all()
    # exact up to the reference's own error (DOP853 at rtol 1e-12): tighter than rimroll's DOP853 at 1e-8
    dop = wp["t_end_error_max"].sel(integrator="rimroll_dop853", scene="rolling_only").sel(rtol=1e-8, method="nearest")
    assert (rolling["t_end_error_max"] < 1e-10).all() and float(rolling["t_end_error_max"].max()) < float(dop)
    assert "rolling-only scene only" in wp["integrator"].attrs["long_name"].split(REDUCED)[1]


def test_rimroll_error_shrinks_as_rtol_tightens_and_stays_near_it(wp):
    for name in ("rimroll_dp5", "rimroll_dop853"):
        err = wp["t_end_error_max"].sel(integrator=name, scene="rolling_only").values  # rtol 1e-6, then 1e-8
        assert err[1] <= err[0]
        assert err[1] < 1e-5  # seconds, over runs of at most 5 s


def test_speed_ratio_is_computed_on_identical_states(wp):
    common = wp["seconds_per_trajectory_common"]
    assert np.isfinite(common.sel(scene="rolling_only")).all()
    assert np.isfinite(speed_ratio(wp)) and speed_ratio(wp) > 0


def test_speed_ratio_is_stored_with_its_spread_and_the_figure_shows_misclassification(wp):
    from rimroll.workflows.work_precision import _plot

    ratio = wp["speed_ratio_rk45_dp5"]
    assert ratio.dims == ("scene",) and ratio.attrs["units"] == "1"
    lo, hi = np.asarray(ratio.attrs["ratio_min_over_rtol"]), np.asarray(ratio.attrs["ratio_max_over_rtol"])
    assert np.all(lo <= ratio.values) and np.all(ratio.values <= hi)
    assert ratio.values[0] == pytest.approx(np.median([speed_ratio(wp, 0, r) for r in wp["rtol"].values]))
    fig = _plot(wp)
    assert len(fig.axes) == 2 * wp.sizes["scene"]  # error and misclassification per scene
    assert "faster" not in fig._suptitle.get_text()  # no run-to-run number in the title
    labels = [t.get_text() for leg in fig.legends for t in leg.get_texts()]
    assert all("states" in lbl for lbl in labels)  # how many states each curve rests on


def test_files_of_the_older_layout_read_the_same(wp):
    """A file written before the labelled dimensions (numeric scene 0..3, numeric ``method`` with
    ``method_name`` labels such as scipy_RK45) gives the same speed ratio, derived ratio and
    figure layout as the labelled one."""
    from rimroll.workflows.work_precision import _derive, _plot, integrator_names

    wp = wp.drop_sel(integrator=[HEYOKA, REDUCED], errors="ignore")  # older files hold the five below
    old = wp.drop_vars("speed_ratio_rk45_dp5").rename({"integrator": "method"})
    old = old.assign_coords(method=np.arange(old.sizes["method"]), scene=np.arange(old.sizes["scene"]))
    old = old.assign_coords(method_name=("method", ["rimroll_dp5", "rimroll_dop853", "scipy_RK45",
                                                    "scipy_DOP853", "scipy_LSODA"]))
    assert integrator_names(old) == [name for name in INTEGRATORS if name not in (HEYOKA, REDUCED)]
    assert speed_ratio(old) == speed_ratio(wp) == speed_ratio(wp, "rolling_only")
    np.testing.assert_array_equal(_derive(old)["speed_ratio_rk45_dp5"][1], wp["speed_ratio_rk45_dp5"].values)
    assert len(_plot(old).axes) == len(_plot(wp).axes)
