"""Regression against the stored reference slices (study/reference_slices, ``study reference --build``).

Each slice (the default grid's sub-grid and the whole ``--quick`` grid) is recomputed at its
study's default precision (outcome sections: dp5, rtol 1e-8, atol 1e-10; the references: DOP853
at rtol 1e-12) on the reference's grid and compared with
``study.compare``: categorical variables must be identical at every point away from boundaries
(all 4-neighbours of the point carry the same values in the reference), continuous variables
must agree within the tolerances below at those points.
"""

from __future__ import annotations

import os
import pathlib
import subprocess
import sys

import numpy as np
import pytest
import xarray as xr

from rimroll.study import compare, reference, registry
from rimroll.study.cli import main, natural_order
from rimroll.study.io import open_result
from rimroll.study.plan import make_plan
from tests.helpers.paths import ROOT
from tests.helpers.study_runs import error_after_notices

# (atol, rtol) per continuous variable, |x - x_ref| <= atol + rtol |x_ref|, and why:
OUTCOME_TOLERANCES = {
    # dp5 at rtol 1e-8 against DOP853 at 1e-12, runs of up to 60 s: observed <= 2.2e-5 s; 10x margin
    "t_end": (2e-4, 2e-4),
    # the minimum of F2 is taken on the dense output (4th order for dp5): observed <= 5e-7 N at 99 %
    # of the points, up to 3.7e-5 N (4.7e-6 of F2 ~ 8 N) on periodic orbits of the rolling-only
    # scene, whose trough falls inside a long dp5 step (the cubic of the step, not the integration)
    "f2_min": (1e-4, 1e-5),
    # omega1 = 0 crossings located on the dense output to the event tolerance: observed <= 3e-9 s
    "half_period": (1e-7, 1e-7),
    # alpha quadrature over the whole run, same error budget as t_end: observed <= 1.4e-5
    "revolutions": (2e-4, 2e-4),
    # slip phases end on the switching tolerances (solver.physics.switching), observed <= 3e-7 s
    "slip_time": (1e-5, 1e-4),
    # conservative: integration drift ~1e-8..1e-7; dissipative: energy lost, O(1): observed <= 6e-7
    "energy_drift": (1e-5, 1e-4),
    # the state at t_end: observed <= 7.4e-8 rad and <= 1.3e-5 1/s (omega2 ~ 100 1/s)
    "beta_end": (1e-6, 1e-6),
    "omega1_end": (1e-4, 1e-5),
    "omega2_end": (1e-4, 1e-5),
    "omega3_end": (1e-4, 1e-5),
    # an integer count: identical away from boundaries
    "slip_phases": (0.0, 0.0),
}
# closed-form maps (fig3, fig5-fig8) and fig9's fixed-step Floquet integration: the same code
# path at any setting, so equal to round-off
MAP_TOLERANCES = {"omega20": (1e-12, 1e-12), "h": (1e-12, 1e-12), "required_friction": (1e-12, 1e-12),
                  "F2": (1e-12, 1e-12), "throw_speed": (1e-12, 1e-12), "trace_M": (1e-10, 1e-10),
                  "abs_mu1": (1e-10, 1e-10), "abs_mu2": (1e-10, 1e-10)}
MIN_AWAY = 0.7  # at least 70 % of a slice lies away from boundaries, or the comparison says little
EVERY_POINT = {"shot", "shot-probability", "rim-states"}  # maps of many small regions (a shot's outcomes), rebuilt
# by the same event-driven code: their categories must be identical at every point instead (a stronger check where
# few points lie away)


# (atol, rtol) of the studies whose reference is more precise than their default run, beyond what
# their variables declare: invariants at DOP853 rtol 1e-10 against 1e-12 (observed <= 3.2e-10 1/s in
# omega1 over 5 s at --quick); the cubes' outcomes as OUTCOME_TOLERANCES (dp5 at rtol 1e-6 against
# DOP853 at 1e-12: observed t_end <= 6.3e-7 s, revolutions <= 3.4e-7)
STUDY_TOLERANCES = {"outcome-cube": OUTCOME_TOLERANCES}
SLOW = {("work-precision", "default"), ("work-precision", "quick"),  # 30 s and 17 s of timed runs, on 2 cores
        ("shot-sensitivity", "default"),  # 12 cases x 4000 noisy shots, a drag case among them: minutes
        ("exact-boundaries", "default")}  # every link of three sections bisected to adjacent doubles: 35 s
# dimensions of ragged lists derived from the whole grid (polylines, crossings): not grid points
RAGGED = {"polyline", "polyline_point", "crossing"}
SLICES = [pytest.param(name, grid, marks=pytest.mark.slow) if (name, grid) in SLOW else (name, grid)
          for name in reference.specs() for grid in reference.GRIDS]


def _tolerances(name, ref):
    if name in STUDY_TOLERANCES:
        return STUDY_TOLERANCES[name]
    return OUTCOME_TOLERANCES if "scene" in ref.dims else MAP_TOLERANCES


def test_every_study_has_a_small_slice_with_provenance():
    own = {ep.name for ep in registry.study_entry_points() if ep.value.startswith("rimroll.")}
    assert own <= set(reference.specs())  # study verify answers 0 or 1 for every study of rimroll
    total = 0
    for (name, grid), spec in (((n, g), reference.specs()[n]) for n in reference.specs() for g in reference.GRIDS):
        path = reference.reference_path(name, grid=grid)
        assert path.is_file(), f"missing {path}: run `study reference --build`"
        size = path.stat().st_size
        total += size
        assert size < 1_000_000
        with xr.open_dataset(path) as ds:
            assert ds.attrs["study"] == name
            for key in ("reference_command", "reference_settings", "reference_rtol", "reference_method",
                        "rimroll_version", "history", "created"):
                assert key in ds.attrs, (name, key)
            assert "study reference --build" in ds.attrs["reference_command"]
            assert ("--quick" in ds.attrs["reference_settings"]) == (grid == "quick")
            if spec.precise:
                assert ds.attrs["reference_rtol"] == "1e-12" and ds.attrs["setting_rtol"] == 1e-12
            # slices built before reference_precision was recorded (the maps', fig11-13's) lack it
            if "reference_precision" in ds.attrs:
                kind = "reference's own" if spec.precise else "regression reference"
                assert kind in ds.attrs["reference_precision"]
            if "boundary_type" in ds:  # the outcome sections, fig11-13
                assert ds.attrs["reference_method"] == "dop853" and ds.attrs["setting_method"] == "dop853"
                assert ds.sizes["beta"] == 24 and ds.sizes["omega1"] == 36 and ds.sizes["scene"] == 4
                assert "boundary_type" in ds
    # the slices ship inside the wheel: 22 studies, two grids each, stay under 6 MB (a budget, 250 kB a study
    # on average; the largest are the four-scene outcome sections, 240 kB each)
    assert total < 6_000_000, f"reference slices total {total / 1e6:.2f} MB, over the 6 MB budget"


def test_the_quick_slice_is_the_whole_quick_grid():
    """What ``study run NAME --quick`` computes, every point of it (so verify covers all of it)."""
    from rimroll.study import registry

    for name in reference.specs():
        with xr.open_dataset(reference.reference_path(name, grid="quick")) as ref:
            for axis in make_plan(registry.get(name), quick=True).axes:
                np.testing.assert_array_equal(ref[axis.name].values, axis.values, err_msg=f"{name} {axis.name}")


@pytest.mark.parametrize("name,grid", SLICES)
def test_default_settings_reproduce_the_reference(name, grid):
    """Each slice recomputed at its study's default precision (the same plan as ``study run NAME
    --quick`` for the quick slice) agrees with the stored one: what ``study verify`` says of a
    fresh run."""
    ds = reference.recompute(name, workers=2, grid=grid)
    ref = open_result(reference.reference_path(name, grid=grid))
    tolerances = _tolerances(name, ref)
    report = compare.compare(ds, ref, tolerances)
    text = "\n".join(compare.format_report(report, f"recomputed {name}", "reference"))
    assert report.n_common == np.prod([n for d, n in ref.sizes.items() if d not in RAGGED]), text
    assert report.ok, text
    cats = [v for v in report.variables if v.kind == "categorical"]
    assert cats or name in ("fig3", "invariants", "work-precision", "shot-sensitivity")
    for v in cats:
        if name in EVERY_POINT:
            assert v.identical == 1.0, text
        else:
            assert v.n_away >= MIN_AWAY * v.n_compared, text
    compared = {v.name for v in report.variables if v.kind == "continuous"}
    assert compared >= (set(tolerances) & set(ref.data_vars)), text
    if name == "fig11":  # the physics the slices pin down: periodic rolling exists in the conservative scenes
        assert (ref["outcome"].values[:2] == 2).any()


def test_a_perturbed_slice_fails():
    """The comparison is not vacuous: one outcome flipped away from boundaries, or t_end off by
    10x its tolerance, fails."""
    ref = open_result(reference.reference_path("fig11"))
    bad = ref.copy(deep=True)
    bad["outcome"].values[0, 0, 0] = 3 - bad["outcome"].values[0, 0, 0]  # a corner, far from any boundary
    assert not compare.compare(bad, ref, OUTCOME_TOLERANCES).ok
    bad = ref.copy(deep=True)
    bad["t_end"].values[0, 0, 0] += 10 * (2e-4 + 2e-4 * float(ref["t_end"].values[0, 0, 0]))
    report = compare.compare(bad, ref, OUTCOME_TOLERANCES)
    assert not report.ok and [v.name for v in report.variables if not v.ok] == ["t_end"]


def test_slices_are_package_data_found_with_importlib(monkeypatch):
    import importlib.resources

    import tomllib

    from rimroll.study import reference

    monkeypatch.delenv(reference.ENV_DIR, raising=False)
    packaged = pathlib.Path(str(importlib.resources.files("rimroll.study") / "reference_slices"))
    assert reference.reference_dir() == packaged
    assert {p.stem for p in packaged.glob("*.nc")} == set(reference.specs())
    assert {p.stem for p in (packaged / "quick").glob("*.nc")} == set(reference.specs())
    root = ROOT
    config = tomllib.loads((root / "pyproject.toml").read_text())
    for pattern in ("reference_slices/*.nc", "reference_slices/quick/*.nc"):
        assert pattern in config["tool"]["setuptools"]["package-data"]["rimroll.study"]


def test_reference_build_never_writes_an_installed_package(monkeypatch, tmp_path, capsys):
    from rimroll.study import reference

    monkeypatch.setattr(reference, "checkout_dir", lambda: None)  # as after pip install
    monkeypatch.delenv(reference.ENV_DIR, raising=False)
    before = {p: p.stat().st_mtime_ns for p in reference.packaged_dir().glob("**/*.nc")}
    assert main(["reference", "--build", "--only", "fig9", "--no-progress"]) == 2
    error_after_notices(capsys.readouterr().err, "needs --out DIR")
    assert {p: p.stat().st_mtime_ns for p in reference.packaged_dir().glob("**/*.nc")} == before


@pytest.mark.slow
def test_verify_after_pip_install(tmp_path):
    """pip install . into a throwaway venv (dependencies from the running interpreter), then verify
    a fig8 result from another directory with the packaged slices."""
    import sysconfig

    root = ROOT
    src = tmp_path / "src"
    files = subprocess.run(["git", "ls-files", "-co", "--exclude-standard"], cwd=root, capture_output=True,
                           text=True, check=True).stdout.split()
    for f in files:
        if (root / f).is_file():
            (src / f).parent.mkdir(parents=True, exist_ok=True)
            (src / f).write_bytes((root / f).read_bytes())
    venv = tmp_path / "venv"
    subprocess.run([sys.executable, "-m", "venv", str(venv)], check=True)
    purelib = "import sysconfig; print(sysconfig.get_paths()['purelib'])"
    site = subprocess.run([str(venv / "bin" / "python"), "-c", purelib],
                          capture_output=True, text=True, check=True).stdout.strip()
    pathlib.Path(site, "zz_deps.pth").write_text(sysconfig.get_paths()["purelib"] + "\n")
    install = subprocess.run([str(venv / "bin" / "pip"), "install", "-q", "--no-deps", str(src)],
                             capture_output=True, text=True, timeout=600)
    if install.returncode != 0:
        pytest.skip(f"pip install . impossible here: {install.stderr.strip().splitlines()[-1:]}")
    env = {k: v for k, v in os.environ.items() if k not in ("PYTHONPATH", "RIMROLL_REFERENCE_DIR")}
    study = str(venv / "bin" / "study")
    run = subprocess.run([study, "run", "fig8", "--out", str(tmp_path / "res"), "--no-progress"], cwd=tmp_path,
                         env=env, capture_output=True, text=True, timeout=600)
    assert run.returncode == 0, run.stderr
    verify = subprocess.run([study, "verify", str(tmp_path / "res" / "fig8.nc")], cwd=tmp_path, env=env,
                            capture_output=True, text=True, timeout=600)
    assert verify.returncode == 0 and "site-packages/rimroll/study/reference_slices/fig8.nc" in verify.stdout, verify
    build = subprocess.run([study, "reference", "--build", "--only", "fig9"], cwd=tmp_path, env=env,
                           capture_output=True, text=True, timeout=600)
    assert build.returncode == 2 and "needs --out" in build.stderr
    # the studies come from the installed entry points; a --quick run verifies against the quick slice
    listed = subprocess.run([study, "list"], cwd=tmp_path, env=env, capture_output=True, text=True, timeout=600)
    assert [line.split()[0] for line in listed.stdout.splitlines()] == natural_order(registry.names())
    quick = subprocess.run([study, "run", "fig8", "--quick", "--out", str(tmp_path / "quick"), "--no-progress"],
                           cwd=tmp_path, env=env, capture_output=True, text=True, timeout=600)
    assert quick.returncode == 0, quick.stderr
    verify = subprocess.run([study, "verify", str(tmp_path / "quick" / "fig8.nc")], cwd=tmp_path, env=env,
                            capture_output=True, text=True, timeout=600)
    shipped = "site-packages/rimroll/study/reference_slices/quick/fig8.nc"
    assert verify.returncode == 0 and shipped in verify.stdout, verify
