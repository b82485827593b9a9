"""When an existing result may stand for a new request (``study.existing_result``): never a result of other inputs,
never a damaged or truncated one.
"""

from __future__ import annotations

import os

import numpy as np
import pytest
import xarray as xr

from rimroll.study.cli import main
from tests.helpers.study_runs import (
    EDITS,
    bit_flipped_copy,
    data_of,
    edited_copy,
    error_after_notices,
    run_probe,
)


def test_result_of_other_inputs_is_not_reused(tmp_path, capsys):
    nc = tmp_path / "fig8.nc"
    assert main(["run", "fig8", "--quick", "--out", str(tmp_path), "--no-progress"]) == 0
    capsys.readouterr()
    assert main(["run", "fig8", "--quick", "--set", "mu=0.1", "--out", str(tmp_path), "--no-progress"]) == 2
    error_after_notices(capsys.readouterr().err, "param_mu 1.0 in the file, 0.1 requested", "--force", "--out")
    with xr.open_dataset(nc) as ds:
        assert ds.attrs["param_mu"] == 1.0
    # a full run after a --quick one differs in the grid
    assert main(["run", "fig8", "--out", str(tmp_path), "--no-progress", "--set", "n_omega30=40"]) == 2
    error_after_notices(capsys.readouterr().err, "setting_n_beta0 121 in the file, 721 requested")
    # the same request is reused; --force replaces the file with the new inputs
    assert main(["run", "fig8", "--quick", "--out", str(tmp_path), "--no-progress"]) == 0
    assert "exists, not recomputing" in capsys.readouterr().out
    assert main(["run", "fig8", "--quick", "--set", "mu=0.1", "--out", str(tmp_path), "--no-progress",
                 "--force"]) == 0
    with xr.open_dataset(nc) as ds:
        assert ds.attrs["param_mu"] == 0.1 and len(ds.attrs["run_fingerprint"]) == 16
    assert sorted(p.name for p in tmp_path.iterdir()) == ["fig8.nc", "fig8.png"]


def test_a_result_changed_on_purpose_is_not_reused_as_its_run(probe, tmp_path, capsys):
    """A file edited with xarray and saved without data_sha256 (as the README says to) keeps the run's
    fingerprint, but its numbers are no longer the run's: the rerun stops in one line and keeps it."""
    assert run_probe(tmp_path) == 0
    nc = tmp_path / "fanout-probe.nc"
    with xr.open_dataset(nc) as ds:
        edited = ds.load()
    edited.attrs.pop("data_sha256")
    edited["f"] = edited["f"] * 2
    edited.to_netcdf(tmp_path / "edited.nc")
    os.replace(tmp_path / "edited.nc", nc)
    capsys.readouterr()
    assert run_probe(tmp_path) == 2
    error_after_notices(capsys.readouterr().err, "no data_sha256", "--force")
    with xr.open_dataset(nc) as ds:
        np.testing.assert_array_equal(ds["f"].values, edited["f"].values)
    assert run_probe(tmp_path, "--force") == 0
    with xr.open_dataset(nc) as ds:
        assert "data_sha256" in ds.attrs


def test_truncated_result_is_recomputed(probe, tmp_path, capsys):
    assert run_probe(tmp_path) == 0
    nc = tmp_path / "fanout-probe.nc"
    good = data_of(nc)
    nc.write_bytes(nc.read_bytes()[: nc.stat().st_size // 2])
    capsys.readouterr()
    assert run_probe(tmp_path) == 0
    captured = capsys.readouterr()
    assert "not a readable result" in captured.err and "wrote" in captured.out
    for k, v in data_of(nc).items():
        np.testing.assert_array_equal(v, good[k])


@pytest.mark.parametrize("edit", ["a value changed", "flipped blocks"])
def test_a_damaged_result_is_recomputed_not_reused(fig8_file, tmp_path, capsys, edit):
    out = tmp_path / "o"
    out.mkdir()
    nc = out / "fig8.nc"
    if edit == "flipped blocks":
        from rimroll.study.io import read_all

        rng = np.random.default_rng(5)
        for _ in range(200):  # flips until one damages what is read (most of the file is data blocks)
            bit_flipped_copy(fig8_file, nc, rng)
            try:
                read_all(nc)
            except Exception:  # noqa: BLE001
                break
        else:
            pytest.fail("no flip damaged the file")
    else:
        edited_copy(fig8_file, nc, EDITS[edit][0])
    assert main(["run", "fig8", "--quick", "--out", str(out), "--no-progress"]) == 0
    captured = capsys.readouterr()
    assert "exists, not recomputing" not in captured.out and f"wrote {nc}" in captured.out
    assert main(["info", str(nc)]) == 0
    with xr.open_dataset(nc) as ds, xr.open_dataset(fig8_file) as good:
        assert ds["region"].equals(good["region"])
