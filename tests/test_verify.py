"""``study verify FILE``: agreement of a results file with the stored reference slice of its study."""

from __future__ import annotations

import numpy as np
import pytest
import xarray as xr

from rimroll.study import reference
from rimroll.study.cli import main


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
    path = tmp_path / "fig12.nc"
    bad.to_netcdf(path)
    assert main(["verify", str(path)]) == 1
    out = capsys.readouterr().out
    assert "FAIL outcome" in out and "FAIL t_end" in out and "NOT within tolerance" in out


def test_other_settings_have_no_common_points(good_fig12, tmp_path, capsys):
    with xr.open_dataset(good_fig12) as ds:
        other = ds.load()
    other.attrs["setting_omega2"] = 70.0
    path = tmp_path / "fig12.nc"
    other.to_netcdf(path)
    assert main(["verify", str(path)]) == 1
    assert "settings differ" in capsys.readouterr().out


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
