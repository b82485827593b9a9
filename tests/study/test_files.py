"""Files that combine: scalar settings as scalar coordinates, CF ``coordinates`` and
``ancillary_variables`` on each variable, label axes as CF character arrays, storage chunks of
about a million values whatever the compute chunks, and the stored reference slices (the layout
before these changes) still compared alike.
"""

from __future__ import annotations

import math

import netCDF4
import numpy as np
import pytest
import xarray as xr

import rimroll
from rimroll.study import registry
from rimroll.study.cli import main
from rimroll.study.plan import STORAGE_VALUES, make_plan, storage_chunks
from tests.helpers.study_runs import run_probe


@pytest.fixture(scope="module")
def two_throws(tmp_path_factory):
    """fig8 --quick at v_throw 7 and 10 m/s, each in its own directory."""
    root = tmp_path_factory.mktemp("throws")
    paths = []
    for v in (7, 10):
        out = root / f"v{v}"
        assert main(["run", "fig8", "--quick", "--set", f"v_throw={v}", "--out", str(out), "--no-progress"]) == 0
        paths.append(out / "fig8.nc")
    return paths


def test_scalar_settings_are_scalar_coordinates(two_throws):
    with xr.open_dataset(two_throws[0]) as ds:
        assert ds["v_throw"].ndim == 0 and float(ds["v_throw"]) == 7.0
        assert ds["v_throw"].attrs["units"] == "m s-1" and ds["v_throw"].attrs["long_name"]
        assert ds["n_beta0"].dtype == np.int32 and int(ds["n_beta0"]) == registry.get("fig8").quick["n_beta0"]
        assert float(ds["mu"]) == ds.attrs["param_mu"] and ds.attrs["setting_v_throw"] == 7.0  # provenance kept
        assert "method" not in ds.coords  # labels stay attributes


def test_two_runs_differing_in_one_setting_open_as_one_dataset(two_throws):
    with xr.open_mfdataset(two_throws, combine="nested", concat_dim="v_throw", combine_attrs="drop_conflicts") as ds:
        assert dict(ds.sizes) == {"v_throw": 2, "beta0": 121, "omega30": 80}
        assert ds["v_throw"].values.tolist() == [7.0, 10.0]
        assert "setting_v_throw" not in ds.attrs and ds.attrs["study"] == "fig8"
        region = ds["region"].sel(v_throw=10.0).load()
    with xr.open_dataset(two_throws[1]) as single:
        np.testing.assert_array_equal(region.values, single["region"].values)
    parts = [xr.open_dataset(p).expand_dims("v_throw") for p in two_throws]
    combined = xr.combine_by_coords(parts, combine_attrs="drop_conflicts")
    assert combined["v_throw"].values.tolist() == [7.0, 10.0] and combined["region"].dims[0] == "v_throw"
    for p in parts:
        p.close()
    with pytest.raises(ValueError, match="v_throw' is swept"):
        rimroll.study.dataset.setting_of(combined, "v_throw")
    assert rimroll.study.dataset.setting_of(combined.sel(v_throw=7.0), "v_throw") == 7.0


def test_coordinates_and_ancillary_variables_on_each_variable(tmp_path):
    sets = ["--set", "n_beta=6", "--set", "n_omega1=5"]
    assert main(["run", "fig11", "--quick", *sets, "--out", str(tmp_path), "--no-progress"]) == 0
    with netCDF4.Dataset(tmp_path / "fig11.nc") as nc:
        assert "coordinates" not in nc.ncattrs()
        coordinates = nc["outcome"].getncattr("coordinates").split()
        assert {"mu", "k_r", "k_d", "t_max", "omega2", "rtol"} <= set(coordinates)
        assert nc["outcome"].getncattr("ancillary_variables") == "status"
        assert "ancillary_variables" not in nc["status"].ncattrs()
        assert nc["boundary_type"].getncattr("coordinates") == nc["outcome"].getncattr("coordinates")
        assert nc["scene"].dtype == "S1" and nc["scene"].dimensions[0] == "scene"  # a CF character array
    with xr.open_dataset(tmp_path / "fig11.nc") as ds:  # plain xarray: labels, aux and scalar coordinates
        assert ds["scene"].values.tolist() == ["rolling_only", "slipping", "drilling", "rolling_resistance"]
        slipping = ds.sel(scene="slipping")
        assert float(slipping["mu"]) == 1.0 and float(slipping["omega2"]) == 35.0


def test_storage_chunks_hold_about_a_million_values_whatever_the_compute_chunks():
    cases = [((3, 5, 6, 3), (1, 1, 4, 3)), ((3600, 2400), (3600, 2400)), ((240, 360), (64, 360)),
             ((2, 2, 2, 2, 24, 36), (1, 1, 1, 1, 24, 36)), ((50, 40, 20, 10, 240, 360), (1, 1, 1, 1, 64, 360)),
             ((7, 1_000_003), (1, 1_000_003))]
    for shape, block in cases:
        sb = storage_chunks(shape, block)
        n = math.prod(sb)
        assert n <= STORAGE_VALUES or all(s == 1 for s in sb[:-1]), (shape, sb)
        assert n >= min(math.prod(shape), STORAGE_VALUES) // 8 or sb[-1] < block[-1], (shape, sb)
        for s, b, full in zip(sb, block, shape):  # a multiple or a divisor of the compute block, or the whole axis
            assert s == full or s % min(b, full) == 0 or min(b, full) % s == 0, (shape, block, sb)
    assert storage_chunks((3600, 2400), (3600, 2400)) == (400, 2400)  # a GPU section split into 7.3 MB chunks
    assert storage_chunks((4, 3, 3, 3, 24, 36), (1, 1, 1, 1, 24, 36)) == (4, 3, 3, 3, 24, 36)  # a cube: all of it


def test_a_cube_is_assembled_in_storage_blocks_with_the_same_numbers(monkeypatch, tmp_path, probe_study):
    """The probe's compute chunks are 1 x 1 x 4 x 3 values; stored in blocks of 1 x 3 x 8 x 3 (a small
    target), every value lands where the probe's formula puts it."""
    from rimroll.study import plan as plan_module

    monkeypatch.setattr(plan_module, "STORAGE_VALUES", 96)
    sets = ["mu=0.5,1,2", "v_throw=1,2,3", "n_x=8"]
    assert main(["run", "fanout-probe", *(w for s in sets for w in ("--set", s)), "--out", str(tmp_path),
                 "--no-progress"]) == 0
    plan = make_plan(registry.get("fanout-probe"), False, {"mu": [0.5, 1, 2], "v_throw": [1, 2, 3], "n_x": 8})
    assert plan.storage == (1, 3, 8, 3) and plan.nc_chunks == (1, 1, 4, 3)  # 6 compute chunks per block
    with xr.open_dataset(tmp_path / "fanout-probe.nc") as ds:
        assert ds["f"].encoding["chunksizes"] == (1, 3, 8, 3)
        x, y = np.meshgrid(ds["x"].values, ds["y"].values, indexing="ij")
        mu, v = ds["mu"].values[:, None, None, None], ds["v_throw"].values[None, :, None, None]
        expect = np.sin(3.0 * x * mu) + v * y + plan.params.rho + plan.params.j
        np.testing.assert_allclose(ds["f"].values, expect, rtol=0, atol=1e-14)
        assert set(np.unique(ds["code"].values)) == {0, 1}


def test_stored_reference_slices_in_the_old_layout_still_verify(tmp_path, capsys):
    """The slices were written before scalar coordinates, per-variable coordinates and character labels;
    a new file is compared with them as before (fig8 --quick against quick/fig8.nc)."""
    from rimroll.study import reference

    old = reference.candidates("fig8", None)
    assert old
    with xr.open_dataset(old[-1]) as ref:
        assert "v_throw" not in ref.coords  # the old layout
    assert main(["run", "fig8", "--quick", "--out", str(tmp_path), "--no-progress"]) == 0
    capsys.readouterr()
    assert main(["verify", str(tmp_path / "fig8.nc")]) == 0
    assert "result: within tolerance" in capsys.readouterr().out
    assert main(["info", str(old[-1])]) == 0 and main(["info", str(tmp_path / "fig8.nc")]) == 0


def test_realisable_cube_with_every_swept_setting_scalar(tmp_path):
    sets = ["--quick", "--set", "mu=1", "--set", "v_throw=5", "--set", "j=0.5", "--set", "rho_over_R=0.5",
            "--set", "n_beta0=24", "--set", "n_omega30=16"]
    assert run_probe(tmp_path, *sets, name="realisable-cube") == 0
    with xr.open_dataset(tmp_path / "realisable-cube.nc") as ds:
        assert ds.area_A.shape == () and ds.region.dims == ("beta0", "omega30")
        assert float(ds.area_A) > 0 and int((ds.region == 1).sum()) > 0
