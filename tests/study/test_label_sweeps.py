"""A setting of labels swept as an outer axis: the ``shot`` study over ``geometry`` (a label axis
whose every slice is the run with that one geometry), and the one-line refusals of a bad label."""

from __future__ import annotations

import numpy as np
import pytest
import xarray as xr

import rimroll
from rimroll.study import cli_text, registry
from rimroll.study.cli import main
from rimroll.study.registry import UserError

shots = pytest.importorskip("rimroll.solver.shots", reason="the solver's shot model is not installed")

SMALL = {"n_speed": 4, "n_angle": 3, "speed_min": 7.0, "speed_max": 7.6}  # a few shots: make, rim, miss


def test_a_geometry_sweep_is_a_label_axis_whose_slices_are_the_single_geometry_runs(tmp_path):
    words = ["geometry=paper,regulation", *(f"{k}={v}" for k, v in SMALL.items())]
    args = ["run", "shot", "--quick", "--out", str(tmp_path), "--no-progress", "--workers", "1"]
    assert main([*args, *(w for word in words for w in ("--set", word))]) == 0
    nc = tmp_path / "shot.nc"
    with xr.open_dataset(nc) as cube:
        assert cube["outcome"].dims == ("geometry", "speed", "angle") and cube.attrs["swept"] == "geometry"
        assert list(cube["geometry"].values.astype(str)) == ["paper", "regulation"]
        assert "setting_geometry" not in cube.attrs and (tmp_path / "shot.png").is_file()
        for name in ("paper", "regulation"):
            one = rimroll.run("shot", quick=True, geometry=name, progress=False, workers=1, **SMALL)
            cut = cube.sel(geometry=name)
            for var in one.data_vars:
                assert np.array_equal(one[var].values, cut[var].values, equal_nan=True), (name, var)
            ring = shots.params_for(name)  # the derived ring follows the label along the axis
            assert (float(cut["ring_R"]), float(cut["ring_a"])) == (ring.R, ring.a)
        fingerprint = cube.attrs["run_fingerprint"]
    assert main(["plot", str(nc), "--select", "geometry=regulation"]) == 0  # a slice's figure, by its label
    assert (tmp_path / "shot_geometry=regulation.png").is_file()
    assert main(["plot", str(nc), "--select", "geometry=hoop"]) == 2
    written = nc.stat().st_mtime_ns
    again = rimroll.run("shot", quick=True, out=tmp_path, geometry=["paper", "regulation"], progress=False, **SMALL)
    assert again.attrs["run_fingerprint"] == fingerprint and nc.stat().st_mtime_ns == written  # reused, as words
    again.close()
    assert rimroll.run("shot", quick=True, geometry=("paper",), progress=False, workers=1, **SMALL).attrs[
        "run_fingerprint"] != fingerprint  # one label is a scalar setting: another run


def test_the_command_line_reads_labels_once(capsys):
    shot = registry.get("shot")
    assert cli_text.setting_values(shot, ["geometry=paper,regulation"]) == {"geometry": ("paper", "regulation")}
    assert cli_text.setting_values(shot, ["geometry=regulation"]) == {"geometry": "regulation"}
    assert main(["run", "shot", "--quick", "--set", "geometry=paper,hoop"]) == 2
    err = capsys.readouterr().err.strip()
    assert err == ("study: error: setting geometry='hoop' is not allowed for study 'shot': allowed geometries are "
                   "paper, regulation")
    assert main(["run", "shot", "--quick", "--set", "geometry=paper:regulation"]) == 2  # no range of labels
    assert "allowed geometries are paper, regulation" in capsys.readouterr().err


@pytest.mark.parametrize("study, value, message", [
    ("shot", ["paper", "hoop"], "setting geometry='hoop' is not allowed for study 'shot': allowed geometries are "
                                "paper, regulation"),
    ("shot", ["paper", 3], "setting geometry=3: expected one of paper, regulation"),
    ("shot", 0.5, "setting geometry=0.5: expected one of paper, regulation"),
    ("rim-states", ("paper", "regulation"), "setting geometry=paper,regulation: geometry takes one of paper, "
                                            "regulation, not a list or range (it cannot be swept in study "
                                            "'rim-states')"),
])
def test_a_bad_label_is_one_line_naming_the_setting_and_the_labels(study, value, message):
    with pytest.raises(UserError) as bad:
        rimroll.run(study, quick=True, geometry=value)
    assert str(bad.value) == message
