"""``study verify FILE``: agreement of a results file with the stored reference slice of its study."""

from __future__ import annotations

import numpy as np
import pytest
import xarray as xr

from rimroll.study import reference
from rimroll.study.cli import main
from rimroll.study.io import CHECKSUM_ATTR
from tests.helpers.study_runs import error_after_notices


@pytest.fixture(scope="module")
def good_fig12(tmp_path_factory):
    """fig12 recomputed at its default settings on the reference's sub-grid, as a results file."""
    path = tmp_path_factory.mktemp("verify") / "fig12.nc"
    reference.recompute("fig12", workers=2).to_netcdf(path)
    return path


def test_good_file_exits_0(good_fig12, capsys):
    assert main(["verify", str(good_fig12)]) == 0
    out = capsys.readouterr().out
    assert "3456 common points" in out and "within tolerance" in out
    for name in ("outcome", "t_end", "half_period", "boundary_type"):
        assert name in out
    assert "% identical" in out and "worst |error|" in out


def test_perturbed_file_exits_1(good_fig12, tmp_path, capsys):
    with xr.open_dataset(good_fig12) as ds:
        bad = ds.load()
    bad["t_end"].values[...] *= 1.01  # 1 % off: 10x the default tolerance of t_end
    bad["outcome"].values[1, 0, 0] = 3 - bad["outcome"].values[1, 0, 0]  # a corner, far from boundaries
    del bad.attrs[CHECKSUM_ATTR]  # changed on purpose: no longer what rimroll wrote (else: damaged, exit 2)
    path = tmp_path / "fig12.nc"
    bad.to_netcdf(path)
    assert main(["verify", str(path)]) == 1
    out = capsys.readouterr().out
    assert "FAIL outcome" in out and "FAIL t_end" in out and "NOT within tolerance" in out


def test_other_settings_have_no_common_points(good_fig12, tmp_path, capsys):
    with xr.open_dataset(good_fig12) as ds:
        other = ds.load()
    other.attrs["setting_omega2"] = 70.0
    del other.attrs[CHECKSUM_ATTR]
    path = tmp_path / "fig12.nc"
    other.to_netcdf(path)
    assert main(["verify", str(path)]) == 1
    out = capsys.readouterr().out
    assert "settings differ" in out and out.count("omega2: 70") == 1


@pytest.mark.parametrize("key, value, default", [("setting_delta", 1e-7, "1e-05"), ("param_c_r", 0.001, "0.0")])
def test_a_setting_the_reference_predates_counts_as_its_default(good_fig12, tmp_path, capsys, key, value, default):
    """A file with a setting or parameter its reference slice does not record (added after the slice was
    made) is compared only at that setting's default."""
    from rimroll.study.compare import compare

    with xr.open_dataset(good_fig12) as ds:
        file = ds.load()
    ref = file.copy()
    ref.attrs.pop(key, None)
    file.attrs[key] = value
    name = key.split("_", 1)[1]
    report = compare(file, ref)
    assert report.n_common == 0 and f"{name}: {value:g} (file) vs {default}" in report.reason, report.reason
    file.attrs[key] = float(default)  # at the default: compared as before
    assert compare(file, ref).ok


def test_a_setting_the_file_does_not_record_is_not_taken_as_equal(good_fig12):
    from rimroll.study.compare import compare

    with xr.open_dataset(good_fig12) as ds:
        file = ds.load()
    ref = file.copy()
    del file.attrs["setting_omega3"]  # an edited file: which omega3 it was computed at is unknown
    if "omega3" in file.coords:  # the scalar coordinate that also says it
        file = file.drop_vars("omega3")
    report = compare(file, ref)
    assert report.n_common == 0 and "omega3: not recorded in the file" in report.reason


def test_quick_run_verifies_against_the_quick_slice(quick_results, capsys):
    """A --quick grid is not a sub-grid of the default one; its study also ships a slice of the
    whole quick grid, and verify takes the slice sharing the most points: all of them."""
    assert main(["verify", str(quick_results / "fig8.nc")]) == 0
    out = capsys.readouterr().out
    assert "9680 common points" in out and str(reference.reference_path("fig8", grid="quick")) in out
    assert "compared: region, omega20" in out and "coverage: 9680 of the reference's 9680 points" in out


def test_full_grid_points_are_verified_against_the_default_slice(good_fig12, capsys):
    assert main(["verify", str(good_fig12)]) == 0
    out = capsys.readouterr().out
    assert f"vs reference {reference.reference_path('fig12')} " in out  # not the quick slice


def test_quick_run_against_the_default_slice_alone_fails_on_coverage(quick_results, tmp_path, capsys):
    """Without its quick slice, a --quick grid shares 2 corners with the default slice: too few to
    vouch for anything (coverage below compare.MIN_COVERAGE)."""
    (tmp_path / "fig8.nc").write_bytes(reference.reference_path("fig8").read_bytes())
    assert main(["verify", str(quick_results / "fig8.nc"), "--reference", str(tmp_path)]) == 1
    out = capsys.readouterr().out
    assert "2 common points" in out and "FAIL coverage" in out and "compared: region, omega20" in out
    # what it compared agrees: the verdict says the coverage, not the values, failed
    assert out.strip().splitlines()[-1].startswith("result: NOT verified: every value compared is within tolerance")
    assert "NOT within tolerance" not in out


@pytest.mark.parametrize("content", ["foreign", "garbage", "missing"])
def test_not_a_rimroll_result_exits_2(tmp_path, capsys, content):
    path = tmp_path / "x.nc"
    if content == "foreign":
        xr.Dataset({"a": ("x", np.arange(3))}).to_netcdf(path)
    elif content == "garbage":
        path.write_text("not netCDF")
    assert main(["verify", str(path)]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and err[0].startswith("study: error: ")


def test_study_without_a_slice_exits_2(good_fig12, tmp_path, capsys):
    assert main(["verify", str(good_fig12), "--reference", str(tmp_path)]) == 2
    assert "no reference slice" in capsys.readouterr().err


def test_reference_build_writes_a_slice_with_provenance(tmp_path, capsys):
    assert main(["reference", "--build", "--only", "fig9", "--out", str(tmp_path), "--workers", "1",
                 "--no-progress"]) == 0
    with xr.open_dataset(tmp_path / "fig9.nc") as ds:
        assert ds.attrs["study"] == "fig9" and "reference --build" in ds.attrs["reference_command"]
        assert ds.sizes == {"rho_over_R": 40, "j": 30}
    with xr.open_dataset(tmp_path / "quick" / "fig9.nc") as ds:  # the whole --quick grid
        assert "--quick" in ds.attrs["reference_settings"] and ds.attrs["setting_n_j"] == 30
    assert main(["verify", str(tmp_path / "fig9.nc")]) == 0
    assert main(["verify", str(tmp_path / "quick" / "fig9.nc")]) == 0
    assert main(["reference", "--build", "--only", "fig9", "--grid", "nope", "--out", str(tmp_path)]) == 2
    assert main(["reference", "--build", "--only", "nope", "--out", str(tmp_path)]) == 2


def test_boundary_types_are_compared_on_the_reference_grid_only():
    """boundary_type describes a cell's neighbours on its own grid: on a finer grid (a full-resolution
    run) the neighbours differ, so verify compares it only on the reference's own grid."""
    from rimroll.study import compare
    from rimroll.study.io import open_result

    ref = open_result(reference.reference_path("fig13"))
    same = ref.copy(deep=True)
    same["boundary_type"].values[0, 0, 0] = 2  # a corner far from any island
    report = compare.compare(same, ref)
    assert not report.ok and [v.name for v in report.variables if not v.ok] == ["boundary_type"]
    beta = ref["beta"].values
    finer = np.sort(np.concatenate([beta, 0.5 * (beta[1:] + beta[:-1])]))
    fine = same.reindex(beta=finer, method="nearest")
    report = compare.compare(fine, ref)
    assert report.ok and "boundary_type" not in {v.name for v in report.variables}
    assert "outcome" in {v.name for v in report.variables}


def test_cubes_verify_against_slices_on_a_few_settings(tmp_path, capsys):
    """A cube's default slice holds some settings at one value (outcome-cube: k_d = 0, omega2 = 65):
    a file that sweeps them is compared at that value; a file that holds at one value what a slice
    sweeps (the README's sweep: k_r = 0) is compared there, and its coverage says how much of the
    slice it checked. Never exit 2 for a study's own file."""
    sets = ["--set", "mu=1,2", "--set", "k_r=0,0.02", "--set", "k_d=0,0.01", "--set", "omega2=65"]
    assert main(["run", "outcome-cube", *sets, "--out", str(tmp_path / "cube"), "--no-progress"]) == 0
    capsys.readouterr()
    assert main(["verify", str(tmp_path / "cube" / "outcome-cube.nc")]) == 0
    out = capsys.readouterr().out
    assert f"vs reference {reference.reference_path('outcome-cube')} " in out
    assert "coverage: 960 of the reference's 960 points" in out
    assert main(["run", "outcome-cube", "--quick", "--set", "mu=0.5,1", "--set", "k_r=0", "--set", "k_d=0",
                 "--set", "omega2=65", "--out", str(tmp_path / "sweep"), "--no-progress"]) == 0
    capsys.readouterr()
    assert main(["verify", str(tmp_path / "sweep" / "outcome-cube.nc")]) == 1
    out = capsys.readouterr().out
    assert "ok   outcome" in out and "FAIL coverage: 432 of the reference's 3456 points" in out


def test_timings_are_named_and_not_compared(tmp_path, capsys):
    """work-precision's output is timing and what it buys: the errors are compared, the seconds not."""
    ref = reference.reference_path("work-precision", grid="quick")
    with xr.open_dataset(ref) as ds:
        other = ds.load()
    other["seconds_per_trajectory"] *= 3.0  # another machine, another day
    other["speed_ratio_rk45_dp5"] *= 0.5
    other.attrs.pop(CHECKSUM_ATTR, None)  # changed on purpose (a slice built since checksums are recorded has them)
    path = tmp_path / "work-precision.nc"
    other.to_netcdf(path)
    assert main(["verify", str(path)]) == 0
    out = capsys.readouterr().out
    assert "not compared" in out and "seconds_per_trajectory" in out and "speed_ratio_rk45_dp5" in out
    assert "ok   misclassified_fraction" in out and "ok   t_end_error_median" in out
    other["misclassified_fraction"] += 0.01
    other.to_netcdf(path)
    assert main(["verify", str(path)]) == 1


def test_the_quick_slices_show_what_the_quick_runs_should(capsys):
    """What the --quick runs promise, read from their stored slices: several types of
    Theorem 1, a misclassification row that is not all zeros on enough states, box entropies with no
    blank strip."""
    with xr.open_dataset(reference.reference_path("solution-types", grid="quick")) as ds:
        assert np.unique(ds["type"].values).size >= 5
    with xr.open_dataset(reference.reference_path("work-precision", grid="quick")) as ds:
        assert (ds["misclassified_fraction"] > 0).any()
        n = ds["n_trajectories"].max("rtol")
        assert int(n.sel(integrator="rimroll_dp5").min()) == 120
        assert int(n.sel(integrator="scipy_rk45", scene="rolling_only")) == 8
        assert int(n.sel(integrator="scipy_rk45").min()) == 3
    with xr.open_dataset(reference.reference_path("predictability", grid="quick")) as ds:
        assert not np.isnan(ds["box_entropy"].values).any()


def test_edited_file_that_keeps_its_checksums_is_damaged(good_fig12, tmp_path, capsys):
    with xr.open_dataset(good_fig12) as ds:
        bad = ds.load()
    bad["t_end"].values[0, 0, 0] += 1.0
    bad.to_netcdf(tmp_path / "fig12.nc")
    assert main(["verify", str(tmp_path / "fig12.nc")]) == 2
    err = capsys.readouterr().err.strip()
    assert err.count("\n") == 0 and "the values of t_end do not match the checksums" in err


@pytest.fixture(scope="module")
def fig8_full(tmp_path_factory):
    """fig8 on the reference's sub-grid at default settings (every slice point, cheap)."""
    from rimroll.study import reference

    path = tmp_path_factory.mktemp("verify8") / "fig8.nc"
    reference.recompute("fig8", workers=1).to_netcdf(path)
    return path


@pytest.mark.parametrize("drop", [["region"], ["region", "omega20"]])
def test_verify_fails_when_a_variable_is_missing(fig8_full, tmp_path, capsys, drop):
    with xr.open_dataset(fig8_full) as ds:
        ds.load().drop_vars(drop).to_netcdf(tmp_path / "fig8.nc")
    # not a result of fig8 at all (one reader validates first): one line, exit 2, not a comparison
    assert main(["verify", str(tmp_path / "fig8.nc")]) == 2
    error_after_notices(capsys.readouterr().err, f"lacks the variable(s) {', '.join(drop)} of study fig8")


def test_verify_states_coverage_and_fails_below_minimum(fig8_full, quick_results, tmp_path, capsys):
    from rimroll.study import reference
    from rimroll.study.compare import MIN_COVERAGE

    assert main(["verify", str(fig8_full)]) == 0
    assert "coverage: 9680 of the reference's 9680 points compared (100.0%" in capsys.readouterr().out
    default_only = tmp_path / "default-slice"  # without the quick slice, a quick grid shares 2 corners
    default_only.mkdir()
    (default_only / "fig8.nc").write_bytes(reference.reference_path("fig8").read_bytes())
    assert main(["verify", str(quick_results / "fig8.nc"), "--reference", str(default_only)]) == 1
    out = capsys.readouterr().out
    assert "FAIL coverage: 2 of the reference's 9680 points" in out and f"needed {100 * MIN_COVERAGE:.0f}%" in out
