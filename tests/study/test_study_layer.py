"""The study layer: files are CF-1.8 netCDF with provenance, the CLI's contract holds."""

from __future__ import annotations

import os
import subprocess
import sys

import numpy as np
import pytest
import xarray as xr

from rimroll.study import registry
from rimroll.study.cli import main

STEADY_STUDIES = ("fig3", "fig5", "fig6", "fig7", "fig8")  # as in conftest.py
PROVENANCE = ("Conventions", "study", "created", "history", "rimroll_version", "param_rho")


@pytest.mark.parametrize("name", STEADY_STUDIES)
def test_quick_run_writes_nc_and_png(quick_results, name):
    assert (quick_results / f"{name}.nc").stat().st_size > 0
    png = (quick_results / f"{name}.png").read_bytes()
    assert png[:8] == b"\x89PNG\r\n\x1a\n"


@pytest.mark.parametrize("name", STEADY_STUDIES)
def test_file_is_cf_with_provenance(quick_results, name):
    with xr.open_dataset(quick_results / f"{name}.nc") as ds:
        for var in [*ds.data_vars.values(), *ds.coords.values()]:
            assert var.attrs.get("units"), var.name
            assert var.attrs.get("long_name"), var.name
            if var.dtype.kind in "iu" and var.name in ds.data_vars:  # categorical (a scalar coordinate: a count)
                assert len(var.attrs["flag_values"]) == len(var.attrs["flag_meanings"].split())
                assert set(np.unique(var.values)) <= set(var.attrs["flag_values"].tolist())
        assert ds.attrs["Conventions"] == "CF-1.8"
        for key in PROVENANCE:
            assert key in ds.attrs, key
        assert ds.attrs["study"] == name
        for p in ("r", "R", "a", "m", "j", "mu", "g", "k_r", "k_d"):
            assert f"param_{p}" in ds.attrs
        assert ds.attrs["setting_n_beta0"] == registry.get(name).quick["n_beta0"]
        assert "--quick" in ds.attrs["history"]
        assert set(ds.sizes) == {"beta0", "omega30"}


def test_compressed_and_chunked(quick_results):
    import netCDF4

    with netCDF4.Dataset(quick_results / "fig8.nc") as nc:
        var = nc["omega20"]
        assert var.filters()["zlib"]
        assert var.chunking() != "contiguous"


def test_set_overrides_and_records(tmp_path):
    assert main(["run", "fig8", "--quick", "--out", str(tmp_path), "--set", "v_throw=3",
                 "--set", "mu=0.5", "--set", "n_omega30=40", "--workers", "1"]) == 0
    with xr.open_dataset(tmp_path / "fig8.nc") as ds:
        assert ds.attrs["setting_v_throw"] == 3.0
        assert ds.attrs["param_mu"] == 0.5
        assert ds.sizes["omega30"] == 40


def test_existing_file_is_not_recomputed(tmp_path, capsys):
    nc = tmp_path / "fig7.nc"
    assert main(["run", "fig7", "--quick", "--out", str(tmp_path)]) == 0
    before = nc.stat().st_mtime_ns
    os.utime(nc, ns=(before - 10**9, before - 10**9))
    capsys.readouterr()
    assert main(["run", "fig7", "--quick", "--out", str(tmp_path)]) == 0
    out = capsys.readouterr().out.strip()
    assert len(out.splitlines()) == 1 and "exists" in out
    assert nc.stat().st_mtime_ns == before - 10**9
    assert main(["run", "fig7", "--quick", "--out", str(tmp_path), "--force"]) == 0
    assert nc.stat().st_mtime_ns != before - 10**9


def test_atomic_write_leaves_no_temp_files(tmp_path):
    assert main(["run", "fig3", "--quick", "--out", str(tmp_path)]) == 0
    assert sorted(p.name for p in tmp_path.iterdir()) == ["fig3.nc", "fig3.png"]


@pytest.mark.parametrize("umask", [0o022, 0o002, 0o077])
def test_results_get_the_permissions_of_any_new_file(tmp_path, umask):
    old = os.umask(umask)
    try:
        (tmp_path / "plain.txt").write_text("any other file")
        assert main(["run", "fig3", "--quick", "--out", str(tmp_path), "--no-progress"]) == 0
    finally:
        os.umask(old)
    expected = (tmp_path / "plain.txt").stat().st_mode & 0o777
    assert expected == 0o666 & ~umask
    for name in ("fig3.nc", "fig3.png"):
        assert (tmp_path / name).stat().st_mode & 0o777 == expected, name


def test_failed_write_leaves_nothing(tmp_path):
    from rimroll.study import io

    with pytest.raises(RuntimeError):
        with io.atomic_path(tmp_path / "x.nc") as tmp:
            tmp.write_text("half")
            raise RuntimeError("interrupted")
    assert list(tmp_path.iterdir()) == []


def test_plot_and_info_from_file(quick_results, tmp_path, capsys):
    png = quick_results / "fig5.png"
    png.unlink()
    assert main(["plot", "fig5", "--out", str(quick_results)]) == 0
    assert png.exists()
    assert main(["plot", str(quick_results / "fig5.nc")]) == 0
    capsys.readouterr()
    assert main(["info", str(quick_results / "fig8.nc")]) == 0
    text = capsys.readouterr().out
    assert "region(beta0, omega30)" in text and "A_inside_above" in text and "history:" in text


def test_list_names_every_steady_study(capsys):
    assert main(["list"]) == 0
    listed = [line.split()[0] for line in capsys.readouterr().out.splitlines()]
    assert set(STEADY_STUDIES) <= set(listed)


@pytest.mark.parametrize("argv, expect", [
    (["run", "nosuch"], "unknown study 'nosuch'; known studies: "),
    (["run", "fig8", "--set", "nokey=1"], "unknown setting 'nokey'"),
    (["run", "fig8", "--set", "mu"], "malformed --set"),
    (["run", "fig8", "--set", "v_throw=fast"], "expected a number"),
    (["run", "fig8", "--set", "j=-1"], "parameter j=-1.0 is out of range"),
    (["run", "fig8", "--set", "a=0.2"], "must be < R"),
    (["run", "fig8", "--set", "n_beta0=1"], "allowed an integer 2 <= n_beta0"),
    (["run", "fig8", "--workers", "0"], "--workers must be between 1 and 1024"),
    (["run"], "required"),
    (["plot", "nosuch.nc"], "no such results file"),
    (["info", "missing.nc"], "no such results file"),
])
def test_user_errors_are_one_line_exit_2(tmp_path, capsys, argv, expect):
    code = main([*argv, *(["--out", str(tmp_path)] if argv[0] == "run" and len(argv) > 1 else [])])
    err = capsys.readouterr().err
    assert code == 2
    assert len(err.strip().splitlines()) == 1
    assert err.startswith("study: error:") and expect in err
    assert "Traceback" not in err
    assert not list(tmp_path.iterdir())


def test_not_a_rimroll_file(tmp_path, capsys):
    xr.Dataset({"x": ("i", np.arange(3.0))}).to_netcdf(tmp_path / "other.nc")
    (tmp_path / "junk.nc").write_text("not netcdf")
    for name in ("other.nc", "junk.nc"):
        assert main(["info", str(tmp_path / name)]) == 2
        err = capsys.readouterr().err
        assert err.startswith("study: error:") and len(err.strip().splitlines()) == 1


def test_entry_point_in_a_subprocess(tmp_path):
    """``python -m rimroll.study`` really runs (the console script calls the same main)."""
    run = subprocess.run([sys.executable, "-m", "rimroll.study", "run", "fig8", "--quick", "--out", str(tmp_path)],
                         capture_output=True, text=True, timeout=120)
    assert run.returncode == 0, run.stderr
    assert (tmp_path / "fig8.nc").exists() and (tmp_path / "fig8.png").exists()
    bad = subprocess.run([sys.executable, "-m", "rimroll.study", "run", "fig8", "--set", "j=-1",
                          "--out", str(tmp_path)], capture_output=True, text=True, timeout=120)
    assert bad.returncode == 2 and bad.stderr.startswith("study: error:") and "Traceback" not in bad.stderr


def test_registry_validates_declarations():
    with pytest.raises(ValueError, match="strictly monotonic"):
        registry.Axis("x", [0.0, 0.0, 1.0], "1", "x")
    with pytest.raises(ValueError, match="flag_values and flag_meanings"):
        registry.Var("v", "1", "v", dtype="int8", flag_values=(0, 1))
    with pytest.raises(registry.UserError, match="known studies: .*fig8"):
        registry.get("nope")
