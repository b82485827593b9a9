"""Runs of the ``study`` command for the tests of the study layer's faults, and the damage done to results.

Most runs use the test-only ``fanout-probe`` study (``tests/helpers/fanout_probe.py``, loaded through
``RIMROLL_STUDY_MODULES``): cheap chunks, so that a case is a second or two.
"""

from __future__ import annotations

import os
import pathlib
import subprocess
import sys

import numpy as np
import xarray as xr

from rimroll.study.cli import main
from rimroll.study.registry import PLUGIN_ENV
from tests.helpers.paths import HELPERS

PROBE = str(HELPERS / "fanout_probe.py")
N_PROBE = 12  # chunks of the probe at its defaults: mu (3) x v_throw (2) x x (2 chunks)


def probe_env(**extra):
    """This process's environment with the probe study loadable, and ``extra``."""
    return {**os.environ, PLUGIN_ENV: PROBE, **extra}


def clean_probe_env(**extra):
    """``probe_env`` without ``FANOUT_PROBE_FAIL_MU``, whatever this process or ``extra`` set it to."""
    env = probe_env(**extra)
    env.pop("FANOUT_PROBE_FAIL_MU", None)
    return env


def run_probe(out, *extra, name="fanout-probe"):
    """``study run NAME --out OUT --no-progress EXTRA...`` in this process; its exit status."""
    return main(["run", name, "--out", str(out), "--no-progress", *extra])


def one_line_error(err: str, *needles):
    """``err`` is one line ``study: error: ...`` holding every one of ``needles``, and no traceback."""
    lines = err.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("study: error:"), err
    assert "Traceback" not in err
    for needle in needles:
        assert needle in lines[0], (needle, lines[0])


def error_after_notices(err: str, *needles):
    """One error line; before it, a run on a cluster may have given the link to its dashboard, and a
    run waiting on a chunk may have said it is working (notices)."""
    lines = [line for line in err.strip().splitlines()
             if ": dashboard of the cluster at " not in line and ": working, " not in line]
    assert len(lines) == 1 and lines[0].startswith("study: error:"), err
    assert "Traceback" not in err
    for needle in needles:
        assert needle in lines[0], (needle, lines[0])


def cli(*args, env=None, timeout=120, **kw):
    """``python -m rimroll.study ARGS...`` in a process of its own (the probe study loadable)."""
    return subprocess.run([sys.executable, "-m", "rimroll.study", *args], capture_output=True, text=True,
                          timeout=timeout, env=env or probe_env(), **kw)


def parts_of(out):
    """The part files of every run under the output folder ``out``."""
    return sorted((pathlib.Path(out) / ".parts").glob("*/chunk-*.npz"))


def data_of(path):
    """Every data variable of the file ``path``, as numpy arrays."""
    with xr.open_dataset(path) as ds:
        return {k: ds[k].values.copy() for k in ds.data_vars}


def edited_copy(src: pathlib.Path, dst: pathlib.Path, change) -> pathlib.Path:
    """A copy of the netCDF file ``src`` at ``dst``, changed in place by ``change(netCDF4.Dataset)``."""
    import shutil

    import netCDF4

    shutil.copy(src, dst)
    with netCDF4.Dataset(dst, "a") as nc:
        change(nc)
    return dst


EDITS = {  # name: (change to a fig8 file, what the one line says)
    "no flag_meanings": (lambda nc: nc["region"].delncattr("flag_meanings"), "flag_values without flag_meanings"),
    "scalar flag_values": (lambda nc: nc["region"].setncattr("flag_values", np.int8(0)), "flag_meanings without"),
    "swept names a label": (lambda nc: nc.setncattr("swept", "beta0 nosuch"), "'swept' attribute names 'nosuch'"),
    "a cube lacking its variables": (lambda nc: nc.setncattr("study", "outcome-cube"), "lacks the variable(s)"),
    "a trace lacking its variables": (lambda nc: nc.setncattr("study", "trace"), "lacks the variable(s)"),
    "another package's study": (lambda nc: nc.setncattr("study", "nosuch"), "no installed package registers"),
    "a value changed": (lambda nc: nc["region"].__setitem__((0, 0), 7), "do not match the checksums"),
    "an attribute changed": (lambda nc: nc.setncattr("param_m", 1.0), "do not match the checksums"),
}


def bit_flipped_copy(src: pathlib.Path, dst: pathlib.Path, rng) -> pathlib.Path:
    """A copy of ``src`` at ``dst`` with 1 to 3 bits flipped at random places (numpy Generator ``rng``)."""
    data = bytearray(src.read_bytes())
    for _ in range(int(rng.integers(1, 4))):
        data[int(rng.integers(len(data)))] ^= 1 << int(rng.integers(8))
    dst.write_bytes(bytes(data))
    return dst
