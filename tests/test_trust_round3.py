"""Faults of issue 42 (third round) whose cases are generated, not listed: the parts folder removed
at any point of a run, SIGTERM (once or twice) at any moment of a run, a cluster that loses its
only worker, client-side TLS mistakes.

The runs use the test-only ``fanout-probe`` study (tests/helpers/fanout_probe.py): cheap chunks, so that a
case is a second or two.
"""

from __future__ import annotations

import importlib
import os
import pathlib
import random
import shutil
import signal
import subprocess
import sys
import threading
import time

import numpy as np
import pytest

from rimroll.study.registry import PLUGIN_ENV, UserError
from tests.helpers.paths import HELPERS

HERE = HELPERS
PROBE = str(HERE / "fanout_probe.py")
# the modules as imported (a plain install's site-packages or a source checkout), not the checkout's paths
WATCHED = {str(pathlib.Path(importlib.import_module(f"rimroll.study.{name}").__file__).resolve())
           for name in ("parts", "assemble", "io", "execute", "fanout")}


def _env(**extra):
    env = {**os.environ, PLUGIN_ENV: PROBE, **extra}
    env.pop("FANOUT_PROBE_FAIL_MU", None)
    return env


# ---------------------------------------------------------------- the parts folder removed mid-run

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
    p = subprocess.Popen(cmd, stderr=subprocess.PIPE, text=True, env=_env())
    deadline = time.monotonic() + 120
    while not list(out.glob(".parts/*/chunk-*.npz")):
        assert p.poll() is None and time.monotonic() < deadline, p.communicate(timeout=30)
        time.sleep(0.05)
    shutil.rmtree(out / ".parts")
    err = p.communicate(timeout=120)[1]
    lines = err.strip().splitlines()
    assert p.returncode == 2 and "Traceback" not in err and len(lines) == 1, err
    assert lines[0].startswith("study: error: ") and "vanished" in lines[0] and "chunks saved" in lines[0]
    again = subprocess.run(cmd, capture_output=True, text=True, env=_env(), timeout=180)
    assert again.returncode == 0, again.stderr
    assert (out / "fanout-probe.nc").is_file()


# ---------------------------------------------------------------- SIGTERM, once or twice, at any moment

def _wait_for_a_sigterm_handler(p: subprocess.Popen) -> None:
    """Wait until process ``p`` catches SIGTERM (Linux: its bit in ``SigCgt`` of /proc/PID/status):
    before that the interpreter is still starting, and SIGTERM has its default action there, as for
    any program."""
    deadline = time.monotonic() + 60
    bit = 1 << (signal.SIGTERM - 1)
    while True:
        assert p.poll() is None and time.monotonic() < deadline, p.communicate(timeout=30)
        try:
            status = pathlib.Path(f"/proc/{p.pid}/status").read_text()
        except OSError:
            status = ""
        caught = [int(line.split()[1], 16) for line in status.splitlines() if line.startswith("SigCgt:")]
        if caught and caught[0] & bit:
            return
        time.sleep(0.005)


def _sigterm_case(out: pathlib.Path, rng: random.Random, n_signals: int, after_chunks: int):
    """Start ``study run fanout-probe``; once ``after_chunks`` chunks are computed (0: at a random
    moment of its start-up), wait a random fraction of a second and send ``n_signals`` SIGTERMs a
    random few milliseconds apart. Returns (exit status, stderr)."""
    log = out.with_suffix(".log")
    cmd = [sys.executable, "-m", "rimroll.study", "run", "fanout-probe", "--out", str(out), "--workers", "2",
           "--set", "delay=0.1", "--set", "n_x=40", "--set", f"log={log}", "--no-progress"]
    p = subprocess.Popen(cmd, stderr=subprocess.PIPE, text=True, env=_env())
    try:
        if after_chunks:
            deadline = time.monotonic() + 120
            while not log.exists() or len(log.read_text().splitlines()) < after_chunks:
                assert p.poll() is None and time.monotonic() < deadline, p.communicate(timeout=30)
                time.sleep(0.01)
            time.sleep(rng.uniform(0, 0.3))
        else:
            _wait_for_a_sigterm_handler(p)
            time.sleep(rng.uniform(0.0, 1.5))
        for _ in range(n_signals):
            p.send_signal(signal.SIGTERM)
            time.sleep(rng.uniform(0, 0.05))
        err = p.communicate(timeout=120)[1]
    finally:
        if p.poll() is None:
            p.kill()
            p.wait(timeout=30)
    return p.returncode, err


@pytest.mark.skipif(not pathlib.Path("/proc/self/status").is_file(), reason="reads /proc/PID/status (Linux)")
@pytest.mark.parametrize("seed", [0, 1, *(pytest.param(s, marks=pytest.mark.slow) for s in range(2, 10))])
def test_one_or_two_sigterms_at_any_moment_are_one_line_and_exit_143(tmp_path, seed):
    """Generated moments (seeded): during the start-up (imports, the cluster coming up) or after a
    random number of chunks, one SIGTERM or two in quick succession. Each: exit 143, one line
    'study: terminated (SIGTERM)...', no traceback (was tornado.application's NameError of dask's
    utils.sync, or exit -15 on the second signal); the rerun resumes to a complete file."""
    rng = random.Random(seed)
    n_signals = 1 + seed % 2
    after = rng.choice([0, rng.randint(1, 20)])
    out = tmp_path / "out"
    status, err = _sigterm_case(out, rng, n_signals, after)
    case = f"seed {seed}: {n_signals} SIGTERM(s) after {after} chunks"
    if status == 0:  # the signals came after the command was done: nothing to say
        return
    lines = err.strip().splitlines()
    assert status == 143 and "Traceback" not in err and len(lines) == 1, f"{case}: {status} {err}"
    assert lines[0].startswith("study: terminated (SIGTERM)"), f"{case}: {err}"
    again = subprocess.run([sys.executable, "-m", "rimroll.study", "run", "fanout-probe", "--out", str(out),
                            "--workers", "2", "--set", "delay=0.1", "--set", "n_x=40",
                            "--set", f"log={out.with_suffix('.log')}", "--no-progress"],
                           capture_output=True, text=True, env=_env(), timeout=300)
    assert again.returncode == 0, again.stderr


def test_a_sigterm_inside_an_import_is_delivered_after_it(monkeypatch):
    """The handler does not raise inside an import (numba's compiled extensions print the interrupt and
    turn it into ImportError): it sends SIGTERM again a moment later, and raises outside the import."""
    from rimroll.study import registry, stopping

    previous = stopping.install()
    assert previous is not None
    seen = []
    try:
        import importlib.util

        # a frame of importlib's bootstrap below the handler's frame: exec a module through importlib
        source = ("import os, signal, time\n"
                  "os.kill(os.getpid(), signal.SIGTERM)\n"
                  "for _ in range(20):\n"
                  "    time.sleep(0.01)\n")
        path = pathlib.Path(os.environ.get("TMPDIR", "/tmp")) / f"rimroll_slow_import_{os.getpid()}.py"
        path.write_text(source)
        try:
            spec = importlib.util.spec_from_file_location("rimroll_slow_import", path)
            module = importlib.util.module_from_spec(spec)
            spec.loader.exec_module(module)  # the SIGTERM lands in here: deferred
            seen.append("import finished")
            deadline = time.monotonic() + 10
            with pytest.raises(registry.Terminated):
                while time.monotonic() < deadline:
                    time.sleep(0.01)
            seen.append("terminated after")
        finally:
            path.unlink()
    finally:
        stopping.restore(previous)
        import signal as _signal

        _signal.signal(_signal.SIGTERM, _signal.SIG_DFL)  # this test process keeps its default action
        stopping.unsilence({name: 0 for name in stopping.TEARDOWN_LOGGERS})
    assert seen == ["import finished", "terminated after"]
    assert threading.main_thread().is_alive()
