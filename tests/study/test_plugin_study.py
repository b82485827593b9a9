"""A study from outside rimroll: another distribution declares it in the entry-point group
``rimroll.studies`` and ``study run`` finds, runs, plots and describes it (the change exercise of
docs/architecture.md: a new study touches only its own module and its package's entry points).

The outside distribution is made in a temporary folder: a module and a ``.dist-info`` folder with
its ``entry_points.txt``, found by ``importlib.metadata`` on the subprocess's ``PYTHONPATH``, as
an installed package's would be.
"""

from __future__ import annotations

import os
import pathlib
import subprocess
import sys
import textwrap

import xarray as xr

TOY_MODULE = '''
"""A toy study of another package: y = a sin(k x) on a grid of x."""

import numpy as np
from matplotlib.figure import Figure

from rimroll.study.registry import Axis, Study, Var, register


def _axes(s):
    return [Axis("x", np.linspace(0.0, 1.0, s["n_x"]), "m", "position along the toy axis")]


def _compute(coords, params, s):
    (x,) = coords
    return {"y": s["amplitude"] * np.sin(s["wavenumber"] * x) + 0.0 * params.g}


def _plot(ds):
    fig = Figure()
    ax = fig.subplots()
    ax.plot(ds["x"], ds["y"])
    ax.set_xlabel("x [m]")
    ax.set_ylabel("y [m]")
    return fig


register(Study(
    name="toy-wave",
    title="A toy wave from a plug-in package",
    settings={"n_x": 21, "amplitude": 2.0, "wavenumber": 3.0},
    quick={"n_x": 7},
    axes=_axes,
    variables=[Var("y", "m", "toy displacement")],
    compute=_compute,
    plot=_plot,
    ignores={k: "the toy wave has no ball" for k in ("r", "R", "a", "m", "j", "mu", "k_r", "k_d")},
))
'''


def _plugin(tmp_path: pathlib.Path) -> dict:
    """The toy distribution on a PYTHONPATH of its own; the environment of a process that sees it."""
    site = tmp_path / "site"
    (site / "toy_wave_plugin-1.0.dist-info").mkdir(parents=True)
    (site / "toy_wave_plugin.py").write_text(textwrap.dedent(TOY_MODULE))
    (site / "toy_wave_plugin-1.0.dist-info" / "METADATA").write_text(
        "Metadata-Version: 2.1\nName: toy-wave-plugin\nVersion: 1.0\n")
    (site / "toy_wave_plugin-1.0.dist-info" / "entry_points.txt").write_text(
        "[rimroll.studies]\ntoy-wave = toy_wave_plugin\n")
    return {**os.environ, "PYTHONPATH": str(site), "MPLBACKEND": "Agg"}


def _study(env, cwd, *args):
    return subprocess.run([sys.executable, "-m", "rimroll.study", *args], env=env, cwd=cwd, capture_output=True,
                          text=True, timeout=300)


def test_a_study_of_another_package_is_found_run_plotted_and_described(tmp_path):
    env = _plugin(tmp_path)
    listing = _study(env, tmp_path, "list")
    assert listing.returncode == 0, listing.stderr
    assert "toy-wave" in listing.stdout and "fig11" in listing.stdout  # beside rimroll's own
    run = _study(env, tmp_path, "run", "toy-wave", "--quick", "--set", "amplitude=0.5", "--out", "out",
                 "--no-progress")
    assert run.returncode == 0, run.stderr
    with xr.open_dataset(tmp_path / "out" / "toy-wave.nc") as ds:
        assert ds.attrs["study"] == "toy-wave" and ds.sizes["x"] == 7
        assert ds["y"].attrs["units"] == "m"
        x = ds["x"].values
        assert abs(ds["y"].values - 0.5 * __import__("numpy").sin(3.0 * x)).max() < 1e-15
    assert (tmp_path / "out" / "toy-wave.png").stat().st_size > 0
    info = _study(env, tmp_path, "info", "toy-wave")
    assert info.returncode == 0, info.stderr
    assert "amplitude" in info.stdout and "A toy wave from a plug-in package" in info.stdout
    refused = _study(env, tmp_path, "run", "toy-wave", "--quick", "--set", "mu=2", "--out", "out2")
    assert refused.returncode == 2 and refused.stderr.count("\n") == 1 and "mu" in refused.stderr


def test_without_the_plugin_the_study_is_unknown(tmp_path):
    """The toy study comes from the plug-in's entry point, not from rimroll itself."""
    env = {k: v for k, v in os.environ.items() if k != "PYTHONPATH"}
    out = _study(env, tmp_path, "info", "toy-wave")
    assert out.returncode == 2 and "'toy-wave' is neither a results file nor a study" in out.stderr
    assert "fig11" in out.stderr  # the studies it knows are listed
