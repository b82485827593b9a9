"""What ``study run`` checks before the work and says after it (``study.run_notices``): the output paths,
the plan of a long run, lanes that did not end ok.
"""

from __future__ import annotations

import os
import pathlib

import pytest
import xarray as xr

from rimroll.study import registry
from rimroll.study.cli import main
from rimroll.study.plan import make_plan
from tests.helpers.study_runs import error_after_notices, one_line_error, run_probe


def test_long_run_prints_its_plan(probe, tmp_path, capsys):
    assert run_probe(tmp_path, "--set", "mu=0.1:1:50", "--set", "n_x=4") == 0
    err = capsys.readouterr().err
    assert "100 of 100 chunks to compute" in err and "Ctrl-C" in err


def test_bad_out_is_one_line(probe, tmp_path, capsys):
    (tmp_path / "file").write_text("x")
    assert run_probe(tmp_path / "file") == 2
    error_after_notices(capsys.readouterr().err, "is not a directory")
    assert run_probe("/proc/rimroll-test") == 2
    error_after_notices(capsys.readouterr().err, "cannot write into --out /proc/rimroll-test")
    if os.geteuid() != 0:  # root writes anywhere
        ro = tmp_path / "ro"
        ro.mkdir()
        ro.chmod(0o500)
        try:
            assert run_probe(ro) == 2
            error_after_notices(capsys.readouterr().err, "cannot write into --out")
        finally:
            ro.chmod(0o700)


def test_lanes_not_ok_are_reported(tmp_path, capsys, monkeypatch):
    from rimroll import solver

    simulate = solver.simulate

    def failing(states, *args, **kw):  # every other lane stopped early as non-finite (flag 3)
        res = dict(simulate(states, *args, **kw))
        res["status"] = res["status"].copy()
        res["status"].reshape(-1)[::2] = 3
        return res

    # omega2 beyond 1e12 is refused up front (the setting table), so the non-ok lanes are injected
    monkeypatch.setattr(solver, "simulate", failing)
    sets = ["--quick", "--set", "mu=1", "--set", "k_r=0", "--set", "k_d=0",
            "--set", "n_beta=4", "--set", "n_omega1=5"]
    assert run_probe(tmp_path, *sets, name="outcome-cube") == 0
    err = capsys.readouterr().err
    with xr.open_dataset(tmp_path / "outcome-cube.nc") as ds:
        bad, total = int((ds.status != 0).sum()), ds.status.size
    assert bad == (total + 1) // 2 and f"warning: {bad} of {total} lanes" in err and "see the variable 'status'" in err


LONG = "x" * 300  # a path component longer than any file system takes (NAME_MAX 255)


def _files(root: pathlib.Path) -> set:
    return {p.relative_to(root) for p in root.rglob("*")} if root.exists() else set()


def _obstacle(out: pathlib.Path, where: str, kind: str) -> None:
    path = out / where
    if kind == "dir":
        (path / "inside").mkdir(parents=True)
    else:
        path.parent.mkdir(parents=True, exist_ok=True)
        path.write_text("not a result")


@pytest.mark.parametrize("where, kind, needle", [
    ("fig8.nc", "dir", "a directory is in the way"),
    ("fig8.png", "dir", "a directory is in the way"),
    (".parts/fig8.lock", "dir", "a directory is in the way"),
    (".parts", "file", "a file is in the way"),
    ("sub", "file", "is not a directory"),
])
def test_run_into_a_colliding_path_is_one_line_and_writes_nothing(tmp_path, capsys, where, kind, needle):
    out = tmp_path / "o"
    _obstacle(out, where, kind)
    before = _files(out)
    target = out / "sub" if where == "sub" else out
    assert main(["run", "fig8", "--quick", "--out", str(target), "--no-progress"]) == 2
    one_line_error(capsys.readouterr().err, needle, str(out / where) if where != "sub" else str(target))
    assert _files(out) == before  # nothing half-written left behind


@pytest.mark.parametrize("argv", [
    ["run", "fig8", "--quick", "--no-progress", "--out", "{tmp}/" + LONG],
    ["run", "fig8", "--quick", "--no-progress", "--out", "{tmp}/" + LONG + "/sub"],
    ["trace", "--state", "1.2,2,0,3", "--t-max", "0.1", "--out", "{tmp}", "--name", LONG],
    ["trace", "--state", "1.2,2,0,3", "--t-max", "0.1", "--out", "{tmp}/f.nc"],  # a file as --out
])
def test_names_too_long_or_files_as_folders_are_one_line(tmp_path, capsys, argv):
    (tmp_path / "f.nc").write_text("x")
    assert main([a.replace("{tmp}", str(tmp_path)) for a in argv]) == 2
    one_line_error(capsys.readouterr().err)
    assert _files(tmp_path) == {pathlib.Path("f.nc")}


@pytest.mark.parametrize("blocked", ["fig8.png", "trace.png", "trace.nc"])
def test_plot_and_trace_onto_a_directory_are_one_line(fig8_file, tmp_path, capsys, blocked):
    import shutil

    shutil.copy(fig8_file, tmp_path / "fig8.nc")
    (tmp_path / blocked).mkdir()
    if blocked == "fig8.png":
        argv = ["plot", str(tmp_path / "fig8.nc")]
    else:
        argv = ["trace", "--state", "1.2,2,0,3", "--t-max", "0.1", "--out", str(tmp_path), "--force"]
    assert main(argv) == 2
    one_line_error(capsys.readouterr().err, str(tmp_path / blocked), "a directory is in the way")
    assert {p.name for p in tmp_path.iterdir()} == {"fig8.nc", blocked}


@pytest.mark.parametrize("name, sets, long", [
    ("make-probability", ["n_samples=100000"], True),  # minutes: the plan says so up front
    ("make-probability", [], False),
    ("solution-types", ["t_max=1000"], True),
    ("fig8", [], False),
])
def test_the_plan_of_a_long_run_is_said_up_front(name, sets, long):
    import io as _io

    from rimroll.study import cli_text, run_notices

    plan = make_plan(registry.get(name), True, cli_text.setting_values(registry.get(name), sets))
    stream = _io.StringIO()
    run_notices.announce(plan, plan.n_chunks, stream)
    text = stream.getvalue()
    assert ("of one core by the study's cost model" in text) == long, text
