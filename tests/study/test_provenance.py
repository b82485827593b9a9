"""Provenance in result files: version, git revision of installed builds, swept axes, CF metadata."""

from __future__ import annotations

import shutil
import subprocess
import sys

import pytest
import xarray as xr

from rimroll.study import dataset
from rimroll.study.cli import main
from tests.helpers.paths import ROOT


def _git_head() -> str | None:
    if shutil.which("git") is None:
        return None
    out = subprocess.run(["git", "rev-parse", "HEAD"], cwd=ROOT, capture_output=True, text=True)
    return out.stdout.strip() or None


def test_a_build_records_the_version_and_git_revision_of_its_source_tree(tmp_path):
    """setuptools-scm writes rimroll/_version.py into a build (pyproject.toml [tool.setuptools_scm]):
    the version from git and the commit, which git_revision of an installed build reads. Built as CI
    builds: from a clean clone with its history."""
    import importlib.util
    import zipfile

    head = _git_head()
    if head is None:
        pytest.skip("not a git checkout")
    src = tmp_path / "clone"
    subprocess.run(["git", "clone", "-q", str(ROOT), str(src)], check=True, capture_output=True, timeout=120)
    local = all(importlib.util.find_spec(m) for m in ("setuptools", "setuptools_scm", "wheel"))  # else isolated
    build = subprocess.run([sys.executable, "-m", "pip", "wheel", "-q", "--no-deps", "-w", str(tmp_path / "dist"),
                            *(["--no-build-isolation"] if local else []), str(src)],
                           capture_output=True, text=True, timeout=600)
    assert build.returncode == 0, build.stderr
    wheel = next((tmp_path / "dist").glob("rimroll-*.whl"))
    with zipfile.ZipFile(wheel) as z:
        names = set(z.namelist())
        record: dict = {}
        exec(z.read("rimroll/_version.py").decode(), record)
    assert record["version"] == wheel.name.split("-")[1] and not record["dirty"]
    assert head.startswith(record["commit"].removeprefix("g")) and len(record["commit"]) >= 8
    assert {"rimroll/py.typed", "rimroll/solver/__init__.py", "rimroll/study/reference_slices/fig8.nc"} <= names
    assert not any(n.startswith(("solver/", "study/", "workflows/")) for n in names)  # nothing else at the top


def test_an_installed_build_reports_its_build_revision(monkeypatch):
    import types

    monkeypatch.setitem(sys.modules, "rimroll._version", types.SimpleNamespace(
        version="0.2.dev3+g0123abc", commit="g0123abc", dirty=True))
    monkeypatch.setattr(dataset, "_git", lambda *args: None)  # not inside a checkout
    dataset.git_revision.cache_clear()
    dataset.rimroll_version.cache_clear()
    try:
        assert dataset.git_revision() == "0123abc-dirty"
        assert dataset.rimroll_version() == "0.2.dev3+g0123abc"
    finally:
        dataset.git_revision.cache_clear()
        dataset.rimroll_version.cache_clear()


def test_the_version_comes_from_git_through_the_build():
    import importlib.metadata

    import rimroll

    assert dataset.rimroll_version() == importlib.metadata.version("rimroll") == rimroll.__version__ != "unknown"
    assert 'dynamic = ["version"]' in (ROOT / "pyproject.toml").read_text()


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
