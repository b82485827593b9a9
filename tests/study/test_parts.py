"""Finished chunks on disk and the run lock (``study.parts``): parts carry their identity, damaged ones
are recomputed, the parts of other inputs are kept, a removed parts folder is one line and the rerun is whole.

The runs use the test-only ``fanout-probe`` study (tests/helpers/fanout_probe.py): cheap chunks, so that a
case is a second or two.
"""

from __future__ import annotations

import importlib
import os
import pathlib
import random
import shutil
import subprocess
import sys
import threading
import time

import numpy as np
import pytest
import xarray as xr

from rimroll.study.cli import main
from rimroll.study.parts import PartStore
from rimroll.study.plan import make_plan
from rimroll.study.registry import UserError
from tests.helpers.study_runs import (
    N_PROBE,
    clean_probe_env,
    data_of,
    error_after_notices,
    one_line_error,
    probe_env,
    run_probe,
)


def _failed_run_with_parts(probe, out, log):
    os.environ["FANOUT_PROBE_FAIL_MU"] = "2.0"
    try:
        with pytest.raises(RuntimeError, match="probe asked to fail"):
            run_probe(out, "--set", f"log={log}", "--workers", "1")
    finally:
        del os.environ["FANOUT_PROBE_FAIL_MU"]
    plan = make_plan(probe, False, {"log": str(log)})
    store = PartStore(out, "fanout-probe", plan.fingerprint)
    kept = sorted(int(p.stem.split("-")[1]) for p in store.dir.glob("chunk-*.npz"))
    assert len(kept) >= 2
    return plan, store, kept


def _other_inputs_parts(tmp_path):
    """Parts folders as an interrupted run of other inputs (this study) and a run of another study leave them."""
    stale = tmp_path / ".parts" / "fanout-probe-0123456789abcdef"
    stale.mkdir(parents=True)
    for k in range(3):
        (stale / f"chunk-{k}.npz").write_bytes(b"x" * 1000)
    other_study = tmp_path / ".parts" / "fig8-0123456789abcdef"
    other_study.mkdir()
    return stale, other_study


def test_lock_covers_the_output_file_whatever_the_inputs(probe, tmp_path, capsys):
    import fcntl

    other = make_plan(probe, False, {"v_throw": 7})  # a run of other inputs holds the output's lock
    store = PartStore(tmp_path, "fanout-probe", other.fingerprint)
    store.root.mkdir(parents=True)
    with open(store.lock_path, "w") as held:
        fcntl.flock(held, fcntl.LOCK_EX | fcntl.LOCK_NB)
        assert run_probe(tmp_path) == 2
    error_after_notices(capsys.readouterr().err, "in progress", str(tmp_path / "fanout-probe.nc"))
    assert not (tmp_path / "fanout-probe.nc").exists()


def test_concurrent_runs_of_different_inputs_never_both_write(tmp_path):
    out = tmp_path / "out"
    cmds = [["run", "fanout-probe", "--out", str(out), "--no-progress", "--workers", "1", "--set", "delay=0.2",
             "--set", f"v_throw={v}"] for v in (1.5, 2.5)]
    procs = [subprocess.Popen([sys.executable, "-m", "rimroll.study", *c], env=probe_env(), stdout=subprocess.PIPE,
                              stderr=subprocess.PIPE, text=True) for c in cmds]
    results = [(p.wait(timeout=120), *p.communicate()) for p in procs]
    assert sorted(r[0] for r in results) == [0, 2], results
    for rc, out_text, err in results:  # the other: in progress, or (if it came later) a file of other inputs
        if rc == 2:
            error_after_notices(err)
            assert "in progress" in err or "holds another run" in err
        else:
            winner = cmds[results.index((rc, out_text, err))]
    with xr.open_dataset(out / "fanout-probe.nc") as ds:
        assert f"v_throw={ds.attrs['setting_v_throw']}" == winner[-1]


def test_part_under_another_chunk_index_is_refused(probe, tmp_path):
    log = tmp_path / "log"
    plan, store, kept = _failed_run_with_parts(probe, tmp_path / "out", log)
    a, b = kept[0], kept[1]
    store.path(a).write_bytes(store.path(b).read_bytes())  # cp chunk-b.npz chunk-a.npz
    assert store.load(a, plan.expected(a)) is None and store.load(b, plan.expected(b)) is not None
    # a part of another run (fingerprint) under the right index is refused too
    foreign = PartStore(tmp_path / "out", "fanout-probe", "0123456789abcdef")
    foreign.dir = store.dir
    foreign.save(b, store.load(b, plan.expected(b)))
    assert store.load(b, plan.expected(b)) is None
    assert run_probe(tmp_path / "out", "--set", f"log={log}", "--workers", "1") == 0
    assert run_probe(tmp_path / "clean", "--set", f"log={tmp_path / 'log2'}") == 0
    clean = data_of(tmp_path / "clean" / "fanout-probe.nc")
    for k, v in data_of(tmp_path / "out" / "fanout-probe.nc").items():
        np.testing.assert_array_equal(v, clean[k], err_msg=k)


def test_flipped_byte_in_zip_directory_is_recomputed(probe, tmp_path):
    log = tmp_path / "log"
    plan, store, kept = _failed_run_with_parts(probe, tmp_path / "out", log)
    path = store.path(kept[0])
    raw = bytearray(path.read_bytes())
    central = raw.index(b"PK\x01\x02")  # first entry of the zip's central directory
    raw[central + 10] ^= 0xFF  # its compression method: numpy raises NotImplementedError
    path.write_bytes(bytes(raw))
    assert store.load(kept[0], plan.expected(kept[0])) is None
    n0 = len(log.read_text().splitlines())
    assert run_probe(tmp_path / "out", "--set", f"log={log}", "--workers", "1") == 0
    assert len(log.read_text().splitlines()) - n0 == N_PROBE - len(kept) + 1


def test_a_computing_run_keeps_and_names_the_parts_of_an_interrupted_run_of_other_inputs(probe, tmp_path, capsys):
    """What a user finished computing is not lost: the interrupted run resumes from its parts."""
    stale, other_study = _other_inputs_parts(tmp_path)
    assert run_probe(tmp_path) == 0
    assert len(list(stale.glob("chunk-*.npz"))) == 3 and other_study.exists()
    assert sorted(p.name for p in (tmp_path / ".parts").iterdir()) == sorted([other_study.name, stale.name])
    err = capsys.readouterr().err
    assert f"{stale} holds 3 chunks saved by an interrupted run of fanout-probe with other settings: kept" in err


def test_a_run_that_reuses_its_file_keeps_the_parts_of_other_inputs(probe, tmp_path, capsys):
    assert run_probe(tmp_path) == 0
    stale, _ = _other_inputs_parts(tmp_path)
    capsys.readouterr()
    assert run_probe(tmp_path) == 0
    out, err = capsys.readouterr()
    assert "exists, not recomputing" in out and f"{stale} holds 3 chunks" in err
    assert len(list(stale.glob("chunk-*.npz"))) == 3


def test_an_interrupted_run_whose_file_another_run_wrote_is_told_that_force_resumes_it(probe, tmp_path, capsys):
    """A interrupted (its chunks saved), B of other settings writes NAME.nc, A again: refused as another
    run's file, and the line says A's chunks wait and --force resumes them; --force does."""
    plan = make_plan(probe, False, {"v_throw": 7})
    store = PartStore(tmp_path, "fanout-probe", plan.fingerprint)  # as A's interrupted run left them
    arrays = {"f": np.zeros((1, 1, 4, 3)), "code": np.zeros((1, 1, 4, 3), dtype=np.int8)}
    store.save(0, arrays)
    assert run_probe(tmp_path) == 0  # B: other settings; A's parts are kept
    capsys.readouterr()
    assert run_probe(tmp_path, "--set", "v_throw=7") == 2
    error_after_notices(capsys.readouterr().err, "holds another run", "1 chunk of this very run, interrupted, wait in",
                        "--force resumes them")
    assert run_probe(tmp_path, "--set", "v_throw=7", "--force") == 0
    with xr.open_dataset(tmp_path / "fanout-probe.nc") as ds:
        assert ds.attrs["run_fingerprint"] == plan.fingerprint


def test_parts_left_by_a_kill_during_cleanup_are_removed(probe, tmp_path, capsys):
    assert run_probe(tmp_path) == 0
    plan = make_plan(probe)
    left = PartStore(tmp_path, "fanout-probe", plan.fingerprint)  # as if killed inside store.remove()
    left.save(0, {"f": np.zeros((1, 1, 4, 3)), "code": np.zeros((1, 1, 4, 3), dtype=np.int8)})
    assert run_probe(tmp_path) == 0 and "exists, not recomputing" in capsys.readouterr().out
    assert not (tmp_path / ".parts").exists()


def test_a_directory_in_a_parts_place_is_cleared_on_rerun(probe, tmp_path, capsys):
    from rimroll.study.parts import PartStore
    from rimroll.study.plan import make_plan

    plan = make_plan(probe)
    store = PartStore(tmp_path, "fanout-probe", plan.fingerprint)
    (store.path(3) / "inside").mkdir(parents=True)
    assert run_probe(tmp_path) == 0
    assert (tmp_path / "fanout-probe.nc").is_file() and not (tmp_path / ".parts").exists()


def test_parts_folder_removed_mid_run_is_one_line_then_resumed(probe, tmp_path, capsys):
    import shutil
    import time

    def remove_parts():
        deadline = time.monotonic() + 30
        while not list(tmp_path.glob(".parts/*/chunk-*.npz")) and time.monotonic() < deadline:
            time.sleep(0.01)
        for d in tmp_path.glob(".parts/fanout-probe-*"):
            shutil.rmtree(d, ignore_errors=True)

    thread = threading.Thread(target=remove_parts)
    thread.start()
    status = run_probe(tmp_path, "--workers", "1", "--set", "delay=0.1")
    thread.join()
    err = capsys.readouterr().err
    if status == 2:  # or the run recomputed what it lost: then exit 0 with a good file
        one_line_error(err, "vanished", "rerun the same command")
        assert run_probe(tmp_path, "--workers", "1") == 0
    assert status in (0, 2) and main(["info", str(tmp_path / "fanout-probe.nc")]) == 0


def test_parts_of_other_code_are_never_assembled_into_a_result(probe, tmp_path, capsys, monkeypatch):
    """Parts left by a run of other code (another code digest: the same inputs, other source) are not
    resumed: every chunk of the file is computed by the code that writes it."""
    from rimroll.study import plan as plan_module

    log = tmp_path / "log"
    monkeypatch.setenv("FANOUT_PROBE_FAIL_MU", "2.0")  # the first run stops part-way, parts kept
    with pytest.raises(RuntimeError, match="probe asked to fail"):
        run_probe(tmp_path / "out", "--workers", "1", "--set", f"log={log}")
    monkeypatch.delenv("FANOUT_PROBE_FAIL_MU")
    kept = list((tmp_path / "out").glob(".parts/*/chunk-*.npz"))
    assert kept
    before = len(log.read_text().splitlines())
    real = plan_module.code_digest
    monkeypatch.setattr(plan_module, "code_digest", lambda study: "other-" + real(study))
    assert run_probe(tmp_path / "out", "--workers", "1", "--set", f"log={log}") == 0
    out, err = capsys.readouterr()
    assert "resumed" not in out
    assert len(log.read_text().splitlines()) - before == 12  # every chunk computed again, none reused
    # the other run's parts are not this run's: left as they were (that code can resume them), and named
    assert all(p.exists() for p in kept) and f"{kept[0].parent} holds {len(kept)} chunk" in err


# the modules as imported (a plain install's site-packages or a source checkout), not the checkout's paths
WATCHED = {str(pathlib.Path(importlib.import_module(f"rimroll.study.{name}").__file__).resolve())
           for name in ("parts", "assemble", "io", "execute", "fanout")}


def _calls_into_the_run_files(action, fire_at=None, doomed=None):
    """Run ``action()`` counting the Python calls made in the main thread into the files that write
    and read a run's parts and result (:data:`WATCHED`); at call number ``fire_at`` remove the folder
    ``doomed``. Returns the number of calls."""
    count = 0
    resolved = {}

    def watched(code) -> bool:
        name = code.co_filename
        if name not in resolved:
            resolved[name] = str(pathlib.Path(name).resolve()) in WATCHED
        return resolved[name]

    def profile(frame, event, arg):
        nonlocal count
        if event == "call" and watched(frame.f_code):
            if count == fire_at:
                shutil.rmtree(doomed, ignore_errors=True)
            count += 1

    sys.setprofile(profile)
    try:
        action()
    finally:
        sys.setprofile(None)
    return count


def _probe_values(ds) -> np.ndarray:
    return np.asarray(ds["f"].values)


def test_the_parts_folder_removed_at_any_point_of_a_run_is_one_error_and_the_rerun_is_whole(tmp_path, probe_study):
    """Every point of a run where the parts folder can vanish (each call into the files that write the
    parts and the result, a seeded sample of them): the run either completes with the right numbers
    or stops with one UserError saying the parts folder vanished and how many chunks are saved; never
    another exception (was FileNotFoundError); the rerun of the same call gives the clean run's
    numbers."""
    import rimroll

    settings = {"mu": [0.5, 1.0], "v_throw": 1.0, "n_x": 16, "workers": 1, "progress": False}
    reference = _probe_values(rimroll.run("fanout-probe", **settings))
    clean = tmp_path / "clean"
    n_calls = _calls_into_the_run_files(lambda: rimroll.run("fanout-probe", out=clean, **settings))
    assert n_calls > 20  # parts written, read back, assembled
    rng = random.Random(42)
    cases = sorted(rng.sample(range(n_calls), min(12, n_calls)))
    stopped = 0
    for i in cases:
        out = tmp_path / f"case{i}"
        outcome = {}

        def action(out=out, outcome=outcome):
            try:
                rimroll.run("fanout-probe", out=out, **settings)
            except UserError as exc:
                outcome["error"] = str(exc)

        _calls_into_the_run_files(action, fire_at=i, doomed=out / ".parts")
        if "error" in outcome:
            stopped += 1
            message = outcome["error"]
            assert "\n" not in message and "vanished" in message and "chunks saved" in message, (i, message)
            assert "rerun the same command" in message
        values = _probe_values(rimroll.run("fanout-probe", out=out, **settings))
        np.testing.assert_array_equal(values, reference, err_msg=f"call {i}")
        assert not (out / ".parts").exists() or not any((out / ".parts").iterdir())
    assert stopped, "no sampled point stopped the run: the sample missed the run itself"


def test_the_parts_folder_removed_while_the_command_runs_is_one_line(tmp_path):
    """The command line: the folder removed while chunks are computed gives one line, exit 2, and
    the rerun completes."""
    out = tmp_path / "out"
    cmd = [sys.executable, "-m", "rimroll.study", "run", "fanout-probe", "--out", str(out), "--workers", "1",
           "--set", "delay=0.2", "--set", "n_x=16", "--no-progress"]
    p = subprocess.Popen(cmd, stderr=subprocess.PIPE, text=True, env=clean_probe_env())
    deadline = time.monotonic() + 120
    while not list(out.glob(".parts/*/chunk-*.npz")):
        assert p.poll() is None and time.monotonic() < deadline, p.communicate(timeout=30)
        time.sleep(0.05)
    shutil.rmtree(out / ".parts")
    err = p.communicate(timeout=120)[1]
    lines = err.strip().splitlines()
    assert p.returncode == 2 and "Traceback" not in err and len(lines) == 1, err
    assert lines[0].startswith("study: error: ") and "vanished" in lines[0] and "chunks saved" in lines[0]
    again = subprocess.run(cmd, capture_output=True, text=True, env=clean_probe_env(), timeout=180)
    assert again.returncode == 0, again.stderr
    assert (out / "fanout-probe.nc").is_file()
