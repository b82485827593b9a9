"""Provenance in result files: version, git revision of installed builds, swept axes, CF metadata."""

from __future__ import annotations

import json
import pathlib
import shutil
import subprocess
import sys

import pytest
import xarray as xr

from rimroll.study import dataset
from rimroll.study.cli import main

ROOT = pathlib.Path(__file__).resolve().parent.parent


def _git_head() -> str | None:
    if shutil.which("git") is None:
        return None
    out = subprocess.run(["git", "rev-parse", "HEAD"], cwd=ROOT, capture_output=True, text=True)
    return out.stdout.strip() or None


def test_build_records_the_git_revision_of_the_source_tree(tmp_path):
    """setup.py's build_py writes rimroll/study/_build_info.json, what an installed build reads."""
    head = _git_head()
    if head is None:
        pytest.skip("not a git checkout")
    subprocess.run([sys.executable, "setup.py", "-q", "build_py", "--build-lib", str(tmp_path)], cwd=ROOT,
                   check=True, capture_output=True)
    info = json.loads((tmp_path / "rimroll" / "study" / "_build_info.json").read_text())
    assert info["git_revision"].removesuffix("-dirty") == head
    assert (tmp_path / "rimroll" / "solver" / "__init__.py").is_file()  # a normal build otherwise
    assert not (tmp_path / "solver").exists()  # nothing named solver at the top


def test_an_installed_build_reports_its_build_revision(tmp_path, monkeypatch):
    info = tmp_path / "_build_info.json"
    info.write_text(json.dumps({"git_revision": "0123abc"}))
    monkeypatch.setattr(dataset, "BUILD_INFO", info)
    dataset.git_revision.cache_clear()
    try:
        assert dataset.git_revision() == "0123abc"
    finally:
        dataset.git_revision.cache_clear()


def test_version_is_the_projects_even_from_a_source_tree():
    text = (ROOT / "pyproject.toml").read_text()
    assert f'version = "{dataset.rimroll_version()}"' in text


def test_swept_settings_are_axes_not_attributes(tmp_path):
    args = ["run", "realisable-cube", "--quick", "--out", str(tmp_path), "--no-progress",
            "--set", "mu=0.5,1", "--set", "v_throw=3,10", "--set", "j=0.5", "--set", "rho_over_R=0.45,0.6",
            "--set", "n_beta0=12", "--set", "n_omega30=8"]
    assert main(args) == 0
    with xr.open_dataset(tmp_path / "realisable-cube.nc") as ds:
        assert ds.attrs["swept"].split() == ["mu", "v_throw", "rho_over_R"]
        for key in ("param_mu", "setting_mu", "setting_v_throw", "setting_rho_over_R", "param_r", "param_rho"):
            assert key not in ds.attrs, key  # they vary along their axis: no single value is "the" setting
        assert ds.attrs["param_j"] == 0.5 and ds.attrs["param_R"] == 0.225
        assert ds["mu"].values.tolist() == [0.5, 1.0] and ds["v_throw"].values.tolist() == [3.0, 10.0]
        point = ds.sel(mu=1.0, v_throw=10.0, rho_over_R=0.6)
        p = dataset.params_of(point)
        assert p.mu == 1.0 and abs(p.rho / p.R - 0.6) < 1e-12 and p.j == 0.5
        with pytest.raises(ValueError, match="swept in this file"):
            dataset.params_of(ds)


def test_cf_global_attributes(quick_results):
    with xr.open_dataset(quick_results / "fig8.nc") as ds:
        assert "Nonlinear dynamics of a basketball rolling around the rim" in ds.attrs["references"]
        assert ds.attrs["source"].startswith(f"rimroll {dataset.rimroll_version()}")
        assert ds.attrs["rimroll_version"] == dataset.rimroll_version() != "unknown"
