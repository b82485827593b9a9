"""Runs you can trust, second round (issue 28): every bad setting, colliding path and damaged file
is one line ``study: error: ...`` and exit 2, before any work and with nothing half-written.

Each class is one generated list of cases (every setting of every study; every path the CLI
writes; every kind of damage to a file), not one test per example of the issue.
"""

from __future__ import annotations

import pathlib

import numpy as np
import pytest
import xarray as xr

from rimroll.study import registry
from rimroll.study.cli import main
from rimroll.study.registry import PHYSICAL_KEYS
from rimroll.study.setting_table import MAX_MAGNITUDE, ORDERED, lookup
from tests.helpers.paths import HELPERS


def _one_line_error(err: str, *needles):
    lines = err.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("study: error:"), err
    assert "Traceback" not in err
    for needle in needles:
        assert needle in lines[0], (needle, lines[0])


def _studies():
    return [registry.get(n) for n in registry.names()
            if registry.get(n).compute.__module__.startswith("rimroll.workflows.")]


# ================================================================ 1. every setting checked before any work
def _numeric_cases():
    """(study, key, value) for every numeric setting of every study: beyond +-1e12 (finite, huge,
    as a list where the setting sweeps) and not a number. Friction coefficients, which take inf,
    are left out."""
    cases = []
    for study in _studies():
        keys = sorted({*study.settings, *study.quick} - set(study.ignores) - {"mu", "rho_over_R"})
        for key in keys:
            default = study.settings.get(key, study.quick.get(key))
            if isinstance(default, bool) or not isinstance(default, (int, float, tuple)) or key in PHYSICAL_KEYS:
                continue
            if lookup(key).range is not None and lookup(key).range.contains(np.inf):
                continue  # a friction coefficient: inf (and any large value) means never slipping
            cases += [(study.name, key, "1e13"), (study.name, key, "-1e300"), (study.name, key, "nan")]
            if key in study.sweepable:
                cases.append((study.name, key, "1e13,2e13"))
    return cases


@pytest.mark.parametrize("name, key, value", _numeric_cases())
def test_every_out_of_range_setting_is_one_line_before_any_work(tmp_path, capsys, name, key, value):
    out = tmp_path / "o"
    assert main(["run", name, "--quick", "--set", f"{key}={value}", "--out", str(out), "--no-progress"]) == 2
    _one_line_error(capsys.readouterr().err, key)
    assert not out.exists()


def test_the_magnitude_bound_is_the_readmes():
    for key in ("v_throw", "omega2", "omega3", "omega30", "sigma"):
        assert lookup(key).problem(MAX_MAGNITUDE) is None and lookup(key).problem(1e13) is not None, key
    # d_omega1 has a range of its own: the integration's steps grow with it (setting_table)
    assert lookup("d_omega1").problem(100.0) is None and lookup("d_omega1").problem(100.5) is not None


@pytest.mark.parametrize("low, high, strict", ORDERED)
def test_ordered_pairs_are_checked_before_any_work(tmp_path, capsys, low, high, strict):
    study = next(s for s in _studies() if low in s.settings and high in s.settings)
    value = study.quick.get(high, study.settings[high])
    for bad in ([value] if strict else [value + 0.1]):
        out = tmp_path / "o"
        assert main(["run", study.name, "--quick", "--set", f"{low}={bad!r}", "--out", str(out)]) == 2
        _one_line_error(capsys.readouterr().err, low, high, "out of order")
        assert not out.exists()


# ================================================================ 2. every path the CLI writes is guarded
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
    _one_line_error(capsys.readouterr().err, needle, str(out / where) if where != "sub" else str(target))
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
    _one_line_error(capsys.readouterr().err)
    assert _files(tmp_path) == {pathlib.Path("f.nc")}


@pytest.fixture(scope="module")
def fig8_file(tmp_path_factory):
    out = tmp_path_factory.mktemp("fig8")
    assert main(["run", "fig8", "--quick", "--out", str(out), "--no-progress"]) == 0
    return out / "fig8.nc"


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
    _one_line_error(capsys.readouterr().err, str(tmp_path / blocked), "a directory is in the way")
    assert {p.name for p in tmp_path.iterdir()} == {"fig8.nc", blocked}


# ================================================================ 3. damaged or foreign files: one reader validates
def _edit(src: pathlib.Path, dst: pathlib.Path, change) -> pathlib.Path:
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


@pytest.mark.parametrize("command", ["info", "plot", "verify"])
@pytest.mark.parametrize("edit", sorted(EDITS))
def test_foreign_or_edited_files_are_one_line(fig8_file, tmp_path, capsys, command, edit):
    change, needle = EDITS[edit]
    path = _edit(fig8_file, tmp_path / "fig8.nc", change)
    assert main([command, str(path)]) == 2
    _one_line_error(capsys.readouterr().err, str(path), needle)
    assert not (tmp_path / "fig8.png").exists()


def _flipped(src: pathlib.Path, dst: pathlib.Path, rng) -> pathlib.Path:
    data = bytearray(src.read_bytes())
    for _ in range(int(rng.integers(1, 4))):
        data[int(rng.integers(len(data)))] ^= 1 << int(rng.integers(8))
    dst.write_bytes(bytes(data))
    return dst


def test_bit_flipped_files_are_refused_or_unchanged(fig8_file, tmp_path, capsys):
    """Seeded random bit flips anywhere in a result: each command either refuses the file in one line
    (exit 2) or the flips hit no value or attribute (free space) and it answers as for the good file."""
    rng = np.random.default_rng(28)
    refused = 0
    with xr.open_dataset(fig8_file) as good:
        good = good.load()
    for k in range(24):
        path = _flipped(fig8_file, tmp_path / f"f{k}.nc", rng)
        for command in ("info", "verify"):
            status = main([command, str(path)])
            captured = capsys.readouterr()
            assert "Traceback" not in captured.err
            if status == 2:
                _one_line_error(captured.err, str(path))
                refused += 1
                continue
            assert status == main([command, str(fig8_file)]), (k, command)
            capsys.readouterr()
            with xr.open_dataset(path) as ds:
                assert ds.load().identical(good), k  # accepted only when nothing that is read changed
    assert refused > 0


def test_select_of_a_non_finite_value_is_one_line():
    from rimroll.study.cli import _selection
    from rimroll.study.registry import UserError

    ds = xr.Dataset(coords={"j": ("j", [0.4, 0.5])}, attrs={"swept": "j"})
    for value in ("nan", "inf", "-inf"):
        with pytest.raises(UserError, match="finite"):
            _selection([f"j={value}"], ds)
    mu = xr.Dataset(coords={"mu": ("mu", [1.0, np.inf])}, attrs={"swept": "mu"})
    assert _selection(["mu=inf"], mu) == {"mu": np.inf}  # an axis that holds inf (rolling only)
    with pytest.raises(UserError, match="finite"):
        _selection(["mu=nan"], mu)


# ================================================================ 5. a damaged result is never reused
@pytest.mark.parametrize("edit", ["a value changed", "flipped blocks"])
def test_a_damaged_result_is_recomputed_not_reused(fig8_file, tmp_path, capsys, edit):
    out = tmp_path / "o"
    out.mkdir()
    nc = out / "fig8.nc"
    if edit == "flipped blocks":
        from rimroll.study.io import read_all

        rng = np.random.default_rng(5)
        for _ in range(200):  # flips until one damages what is read (most of the file is data blocks)
            _flipped(fig8_file, nc, rng)
            try:
                read_all(nc)
            except Exception:  # noqa: BLE001
                break
        else:
            pytest.fail("no flip damaged the file")
    else:
        _edit(fig8_file, nc, EDITS[edit][0])
    assert main(["run", "fig8", "--quick", "--out", str(out), "--no-progress"]) == 0
    captured = capsys.readouterr()
    assert "exists, not recomputing" not in captured.out and f"wrote {nc}" in captured.out
    assert main(["info", str(nc)]) == 0
    with xr.open_dataset(nc) as ds, xr.open_dataset(fig8_file) as good:
        assert ds["region"].equals(good["region"])


# ================================================================ 4. no long run is silent
@pytest.mark.parametrize("name, sets, long", [
    ("make-probability", ["n_samples=100000"], True),  # minutes: the plan says so up front
    ("make-probability", [], False),
    ("solution-types", ["t_max=1000"], True),
    ("fig8", [], False),
])
def test_the_plan_of_a_long_run_is_said_up_front(name, sets, long):
    import io as _io

    from rimroll.study import runguard
    from rimroll.study.plan import make_plan

    plan = make_plan(registry.get(name), True, sets)
    stream = _io.StringIO()
    runguard.announce(plan, plan.n_chunks, stream)
    text = stream.getvalue()
    assert ("of one core by the study's cost model" in text) == long, text


def test_absurdly_large_runs_are_refused_with_the_bound(tmp_path, capsys):
    from rimroll.study import runguard

    out = tmp_path / "o"
    argv = ["run", "make-probability", "--set", "n_beta=20000", "--set", "n_omega1=20000",
            "--set", "n_samples=100000", "--out", str(out)]
    assert main(argv) == 2
    _one_line_error(capsys.readouterr().err, "of one core", runguard._duration(runguard.MAX_CORE_SECONDS))
    assert not (out / "make-probability.nc").exists() and not (out / ".parts").exists()


def test_a_chunk_that_takes_long_is_not_silent(tmp_path, capsys, monkeypatch):
    """One worker, chunks of 2.5 s: a "working" notice within the first chunk, the run ends fine."""
    probe = str(HELPERS / "fanout_probe.py")
    monkeypatch.setenv(registry.PLUGIN_ENV, probe)
    argv = ["run", "fanout-probe", "--set", "mu=1", "--set", "v_throw=1", "--set", "delay=2.5",
            "--workers", "1", "--no-progress", "--out", str(tmp_path)]
    assert main(argv) == 0
    err = capsys.readouterr().err
    assert "fanout-probe: working, 0 of 2 chunks done after 2 s" in err, err


# ================================================================ 5. faults around a run
@pytest.fixture
def probe(monkeypatch):
    monkeypatch.setenv(registry.PLUGIN_ENV, str(HELPERS / "fanout_probe.py"))
    monkeypatch.delenv("FANOUT_PROBE_FAIL_MU", raising=False)
    return registry.get("fanout-probe")


def _probe(out, *extra):
    return main(["run", "fanout-probe", "--out", str(out), "--no-progress", *extra])


def test_disk_full_from_the_start_is_one_line(probe, tmp_path, capsys, monkeypatch):
    import errno
    import os

    from rimroll.study import parts

    def full(fd, data):
        raise OSError(errno.ENOSPC, os.strerror(errno.ENOSPC))

    monkeypatch.setattr(parts.os, "write", full)  # the first write of a run: the lock's pid
    assert _probe(tmp_path) == 2
    _one_line_error(capsys.readouterr().err, "No space left on device", "0 of 12 chunks saved")


def test_a_directory_in_a_parts_place_is_cleared_on_rerun(probe, tmp_path, capsys):
    from rimroll.study.parts import PartStore
    from rimroll.study.plan import make_plan

    plan = make_plan(probe)
    store = PartStore(tmp_path, "fanout-probe", plan.fingerprint)
    (store.path(3) / "inside").mkdir(parents=True)
    assert _probe(tmp_path) == 0
    assert (tmp_path / "fanout-probe.nc").is_file() and not (tmp_path / ".parts").exists()


def test_parts_folder_removed_mid_run_is_one_line_then_resumed(probe, tmp_path, capsys):
    import shutil
    import threading
    import time

    def remove_parts():
        deadline = time.monotonic() + 30
        while not list(tmp_path.glob(".parts/*/chunk-*.npz")) and time.monotonic() < deadline:
            time.sleep(0.01)
        for d in tmp_path.glob(".parts/fanout-probe-*"):
            shutil.rmtree(d, ignore_errors=True)

    thread = threading.Thread(target=remove_parts)
    thread.start()
    status = _probe(tmp_path, "--workers", "1", "--set", "delay=0.1")
    thread.join()
    err = capsys.readouterr().err
    if status == 2:  # or the run recomputed what it lost: then exit 0 with a good file
        _one_line_error(err, "vanished", "rerun the same command")
        assert _probe(tmp_path, "--workers", "1") == 0
    assert status in (0, 2) and main(["info", str(tmp_path / "fanout-probe.nc")]) == 0


@pytest.mark.parametrize("delay", [0.2, 0.5, 0.9, 1.4])
def test_ctrl_c_during_start_up_is_one_line(tmp_path, delay):
    import shutil
    import signal
    import subprocess
    import sys
    import time

    script = shutil.which("study", path=str(pathlib.Path(sys.executable).parent)) or shutil.which("study")
    if script is None:
        pytest.skip("the study console script is not installed")
    run = subprocess.Popen([script, "run", "fig8", "--quick", "--out", str(tmp_path / "o"), "--no-progress"],
                           stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    time.sleep(delay)
    run.send_signal(signal.SIGINT)
    out, err = run.communicate(timeout=120)
    assert "Traceback" not in err and run.returncode in (0, 130), (run.returncode, err)
    if run.returncode == 130:
        assert len(err.strip().splitlines()) == 1 and "interrupted" in err, err


# ================================================================ the fuzz: random settings and damaged files
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
        _one_line_error(captured.err)
        if "its figure cannot be drawn" not in captured.err:
            assert not (tmp / f"run{k}" / f"{study.name}.nc").exists(), argv
    else:
        open_result(tmp / f"run{k}" / f"{study.name}.nc").close()  # a valid file


def _fuzz_file(rng, good: pathlib.Path, tmp: pathlib.Path, capsys, k: int) -> None:
    import netCDF4

    path = tmp / f"file{k}.nc"
    if rng.random() < 0.5:
        _flipped(good, path, rng)
    else:
        edit = sorted(EDITS)[int(rng.integers(len(EDITS)))]
        _edit(good, path, EDITS[edit][0])
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
        _one_line_error(captured.err)


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


@pytest.mark.parametrize("sets", [["j=1e308"], ["j=1e200", "g=1e200"], ["k_r=1e12"]])
def test_physical_parameters_beyond_1e12_are_refused_before_work(tmp_path, capsys, sets):
    """Physical parameters are checked by Params' own ranges (positive, below 1e12, as the README says
    of every number) before any work: j = 1e308 overflowed (1+j)**2 inside a chunk."""
    argv = ["run", "fig5", "--quick", "--no-progress", "--out", str(tmp_path)]
    for item in sets:
        argv += ["--set", item]
    assert main(argv) == 2
    err = capsys.readouterr().err
    lines = err.strip().splitlines()
    assert len(lines) == 1 and "Traceback" not in err and "1e12" in lines[0], err
    assert not (tmp_path / "fig5.nc").exists()


# ================================================================ 7. damaged local state
def test_file_size_limit_between_the_netcdf_and_the_png_is_one_line(tmp_path, capsys, monkeypatch):
    import errno
    import os

    from rimroll.study import io as study_io

    def too_large(fig, path, dpi=120):
        raise OSError(errno.EFBIG, os.strerror(errno.EFBIG), str(path))

    monkeypatch.setattr(study_io, "write_figure", too_large)
    assert main(["run", "fig8", "--quick", "--no-progress", "--out", str(tmp_path)]) == 2
    _one_line_error(capsys.readouterr().err, "File too large", str(tmp_path / "fig8.png"))
    monkeypatch.undo()
    assert main(["run", "fig8", "--quick", "--no-progress", "--out", str(tmp_path)]) == 0  # the file is kept
    assert "exists, not recomputing" in capsys.readouterr().out and (tmp_path / "fig8.png").is_file()


# ================================================================ 6. cluster faults
def test_scheduler_killed_mid_run_is_one_line_then_resumed(tmp_path):
    import os
    import signal
    import socket
    import subprocess
    import sys
    import time

    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        port = s.getsockname()[1]
    address = f"tcp://127.0.0.1:{port}"
    env = {**os.environ, registry.PLUGIN_ENV: str(HELPERS / "fanout_probe.py")}
    dask = [sys.executable, "-m"]
    scheduler = subprocess.Popen([*dask, "distributed.cli.dask_scheduler", "--host", "127.0.0.1", "--port", str(port),
                                  "--no-dashboard"], env=env, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    worker = None
    out = tmp_path / "out"
    try:
        worker = subprocess.Popen([*dask, "distributed.cli.dask_worker", address, "--no-nanny", "--nthreads", "1",
                                   "--no-dashboard"], env=env, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
        run = subprocess.Popen([sys.executable, "-m", "rimroll.study", "run", "fanout-probe", "--out", str(out),
                                "--no-progress", "--scheduler", address, "--timeout", "20", "--set", "delay=0.3"],
                               env=env, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
        deadline = time.monotonic() + 90
        while len(list(out.glob(".parts/*/chunk-*.npz"))) < 2:
            assert run.poll() is None and time.monotonic() < deadline, run.communicate()
            time.sleep(0.05)
        scheduler.send_signal(signal.SIGKILL)
        t0 = time.monotonic()
        _, err = run.communicate(timeout=60)
        assert time.monotonic() - t0 < 20  # within the --timeout
    finally:
        for p in (scheduler, worker):
            if p is not None:
                p.kill()
                p.wait(timeout=10)
    lines = [line for line in err.strip().splitlines() if line.startswith("study: error:") or "Trace" in line]
    assert run.returncode == 2 and len(lines) == 1, err  # notices (dashboard, working) may come before
    assert "scheduler lost" in lines[0] and "chunks saved" in lines[0] and "Traceback" not in err
    rerun = subprocess.run([sys.executable, "-m", "rimroll.study", "run", "fanout-probe", "--out", str(out),
                            "--no-progress", "--set", "delay=0.3"], env=env, capture_output=True, text=True,
                           timeout=120)  # the same inputs, locally: the saved chunks are resumed
    assert rerun.returncode == 0 and "chunks resumed" in rerun.stdout, rerun.stderr


# ================================================================ 8. chunks of different code never mix
def test_parts_of_other_code_are_never_assembled_into_a_result(probe, tmp_path, capsys, monkeypatch):
    """Parts left by a run of other code (another code digest: the same inputs, other source) are not
    resumed: every chunk of the file is computed by the code that writes it."""
    from rimroll.study import plan as plan_module

    log = tmp_path / "log"
    monkeypatch.setenv("FANOUT_PROBE_FAIL_MU", "2.0")  # the first run stops part-way, parts kept
    with pytest.raises(RuntimeError, match="probe asked to fail"):
        _probe(tmp_path / "out", "--workers", "1", "--set", f"log={log}")
    monkeypatch.delenv("FANOUT_PROBE_FAIL_MU")
    kept = list((tmp_path / "out").glob(".parts/*/chunk-*.npz"))
    assert kept
    before = len(log.read_text().splitlines())
    real = plan_module.code_digest
    monkeypatch.setattr(plan_module, "code_digest", lambda study: "other-" + real(study))
    assert _probe(tmp_path / "out", "--workers", "1", "--set", f"log={log}") == 0
    out, err = capsys.readouterr()
    assert "resumed" not in out
    assert len(log.read_text().splitlines()) - before == 12  # every chunk computed again, none reused
    # the other run's parts are not this run's: left as they were (that code can resume them), and named
    assert all(p.exists() for p in kept) and f"{kept[0].parent} holds {len(kept)} chunk" in err
