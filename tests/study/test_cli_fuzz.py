"""Seeded random settings on quick runs and random damage to the files given to the commands: every
answer is a result or one line.
"""

from __future__ import annotations

import pathlib

import numpy as np

from rimroll.study import registry
from rimroll.study.cli import main
from rimroll.study.registry import PHYSICAL_KEYS
from tests.helpers.study_runs import EDITS, bit_flipped_copy, edited_copy, one_line_error

FUZZ_SECONDS = 45.0  # the test's bound on its own work (each case checks the bound of its command too)


FUZZ_STUDIES = ("fig3", "fig5", "fig8", "fig9")  # --quick runs of about a second: many cases per minute


NASTY = ("nan", "inf", "-inf", "1e13", "-1e13", "1e308", "-1", "0", "1e-300", "abc", "", "1,2", "2,1",
         "1:2:3", "1:1:2", "0:1:1", "1,,2", "1e12", "-0", "0x10", "3.5", "1e-20")


def _fuzz_value(rng) -> str:
    if rng.random() < 0.6:
        return NASTY[int(rng.integers(len(NASTY)))]
    return repr(float(rng.normal() * 10.0 ** int(rng.integers(-15, 16))))


def _fuzz_run(rng, tmp: pathlib.Path, capsys, k: int) -> None:
    import time

    from rimroll.study.io import open_result

    study = registry.get(FUZZ_STUDIES[int(rng.integers(len(FUZZ_STUDIES)))])
    keys = sorted({*study.settings, *study.quick, *PHYSICAL_KEYS} - set(study.ignores))
    sets = [f"{keys[int(rng.integers(len(keys)))]}={_fuzz_value(rng)}" for _ in range(int(rng.integers(1, 3)))]
    argv = ["run", study.name, "--quick", "--no-progress", "--out", str(tmp / f"run{k}")]
    for item in sets:
        argv += ["--set", item]
    t0 = time.monotonic()
    status = main(argv)  # an exception here is a traceback a user would see
    captured = capsys.readouterr()
    assert time.monotonic() - t0 < 30, argv
    assert status in (0, 2), (argv, captured.err)
    if status == 2:
        one_line_error(captured.err)
        if "its figure cannot be drawn" not in captured.err:
            assert not (tmp / f"run{k}" / f"{study.name}.nc").exists(), argv
    else:
        open_result(tmp / f"run{k}" / f"{study.name}.nc").close()  # a valid file


def _fuzz_file(rng, good: pathlib.Path, tmp: pathlib.Path, capsys, k: int) -> None:
    import netCDF4

    path = tmp / f"file{k}.nc"
    if rng.random() < 0.5:
        bit_flipped_copy(good, path, rng)
    else:
        edit = sorted(EDITS)[int(rng.integers(len(EDITS)))]
        edited_copy(good, path, EDITS[edit][0])
        if rng.random() < 0.5:  # and a second damage: an attribute of a variable replaced by nonsense
            with netCDF4.Dataset(path, "a") as nc:
                var = nc[sorted(nc.variables)[int(rng.integers(len(nc.variables)))]]
                var.setncattr(["flag_values", "flag_meanings", "units"][int(rng.integers(3))], "nonsense")
    command = ["info", "plot", "verify"][int(rng.integers(3))]
    argv = [command, str(path)]
    if command == "plot" and rng.random() < 0.5:
        argv += ["--select", f"beta0={_fuzz_value(rng)}"]
    status = main(argv)
    captured = capsys.readouterr()
    assert status in (0, 1, 2), (argv, captured.err)  # verify: 1 is a disagreement, reported in full
    if status == 2:
        one_line_error(captured.err)


def test_fuzz_random_settings_and_damaged_files(fig8_file, tmp_path, capsys):
    """Seeded: random --set values on quick runs and random damage to files given to info, plot and
    verify, for at most a minute: exit 0 (a valid file) or 2 (one line), never a traceback."""
    import time

    rng = np.random.default_rng(2028)
    t0, k = time.monotonic(), 0
    while time.monotonic() - t0 < FUZZ_SECONDS or k < 8:
        if k % 2:
            _fuzz_file(rng, fig8_file, tmp_path, capsys, k)
        else:
            _fuzz_run(rng, tmp_path, capsys, k)
        k += 1
        if k >= 400:
            break
    assert k >= 8
