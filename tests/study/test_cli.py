"""The ``study`` command's own faults: a file it cannot show, a closed pipe, a Python warning; each one line."""

from __future__ import annotations

import subprocess
import sys

import xarray as xr

from rimroll.study import registry
from rimroll.study.cli import main
from tests.helpers.study_runs import cli, error_after_notices


def test_plot_of_a_file_missing_a_variable(quick_results, tmp_path, capsys):
    with xr.open_dataset(quick_results / "fig8.nc") as ds:
        ds.load().drop_vars("region").to_netcdf(tmp_path / "fig8.nc")
    assert main(["plot", str(tmp_path / "fig8.nc")]) == 2
    error_after_notices(capsys.readouterr().err, "lacks the variable(s) region")


def test_info_of_a_file_with_label_coordinates(tmp_path, capsys):
    names = [v.name for v in registry.get("work-precision").variables]  # a file of the study has them all
    ds = xr.Dataset({name: (("integrator",), [1e-4, 2e-4], {"units": "s"}) for name in names},
                    coords={"integrator": ("integrator", ["rimroll_dop853", "scipy_RK45"], {"units": "1"})},
                    attrs={"study": "work-precision", "rimroll_version": "0"})
    ds.to_netcdf(tmp_path / "wp.nc")
    assert main(["info", str(tmp_path / "wp.nc")]) == 0
    assert "rimroll_dop853, scipy_RK45 (2 points)" in capsys.readouterr().out


def test_info_into_a_closed_pipe(quick_results):
    cmd = f"{sys.executable} -m rimroll.study info {quick_results / 'fig8.nc'} | head -c 10 >/dev/null"
    run = subprocess.run(["bash", "-o", "pipefail", "-c", cmd], capture_output=True, text=True, timeout=120)
    assert "Traceback" not in run.stderr and "BrokenPipe" not in run.stderr and run.returncode == 0, run.stderr


def test_a_python_warning_during_a_command_is_one_line(tmp_path):
    """numpy's overflow at an extreme (valid) setting printed Python's two lines, the second the source;
    the command prints one, naming the warning and where it came from, and its exit status stands."""
    run = cli("run", "fig8", "--quick", "--set", "j=1e-300", "--out", str(tmp_path), "--no-progress")
    assert run.returncode == 0, run.stderr
    lines = run.stderr.strip().splitlines()
    assert lines and all(line.startswith("study: ") for line in lines), run.stderr
    assert any(line.startswith("study: warning: RuntimeWarning: overflow") for line in lines)
