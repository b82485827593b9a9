"""Ctrl-C and SIGTERM to the ``study`` command (``study.stopping``): one stop, one line, what was saved,
at any moment of a run.
"""

from __future__ import annotations

import os
import pathlib
import random
import shutil
import signal
import subprocess
import sys
import threading
import time

import pytest

from rimroll.study import registry
from tests.helpers.study_runs import clean_probe_env, cli, parts_of, probe_env, run_probe


@pytest.mark.parametrize("sig, status, word", [(signal.SIGINT, 130, "study: interrupted;"),
                                               (signal.SIGTERM, 143, "study: terminated (SIGTERM);")])
def test_ctrl_c_says_what_was_saved(tmp_path, sig, status, word):
    """Ctrl-C, and SIGTERM as ``timeout`` or a batch system sends it (it killed the run with no word and
    left the lock file), stop a run in one line saying what was saved; the rerun resumes."""
    out = tmp_path / "out"
    proc = subprocess.Popen([sys.executable, "-m", "rimroll.study", "run", "fanout-probe", "--out", str(out),
                             "--no-progress", "--workers", "1", "--set", "delay=0.3"], env=probe_env(),
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    deadline = time.monotonic() + 60
    while len(parts_of(out)) < 2:
        assert proc.poll() is None and time.monotonic() < deadline, proc.communicate()
        time.sleep(0.02)
    proc.send_signal(sig)
    _, err = proc.communicate(timeout=60)
    assert proc.returncode == status, err
    lines = err.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith(word) and "chunks saved" in lines[0] and "Traceback" not in err
    assert not list((out / ".parts").glob("*.lock"))
    rerun = cli("run", "fanout-probe", "--out", str(out), "--no-progress", "--workers", "1", "--set", "delay=0.3")
    assert rerun.returncode == 0 and "chunks resumed" in rerun.stdout, rerun.stderr


def test_ctrl_c_while_the_figure_is_drawn_says_the_result_is_complete(probe, tmp_path, capsys, monkeypatch):
    """The .nc is written when the figure is drawn: a Ctrl-C there said only 'interrupted'."""
    from rimroll.study import cli

    def drawing(*args, **kwargs):
        raise KeyboardInterrupt

    monkeypatch.setattr(cli, "_draw", drawing)
    assert run_probe(tmp_path) == 130
    err = capsys.readouterr().err.strip()
    assert err.startswith("study: interrupted while drawing the figure;") and "\n" not in err
    assert f"{tmp_path / 'fanout-probe.nc'} is complete" in err and (tmp_path / "fanout-probe.nc").is_file()


@pytest.mark.parametrize("delay", [0.2, 0.5, 0.9, 1.4])
def test_ctrl_c_during_start_up_is_one_line(tmp_path, delay):
    import signal
    import subprocess
    import sys
    import time

    script = shutil.which("study", path=str(pathlib.Path(sys.executable).parent)) or shutil.which("study")
    if script is None:
        pytest.skip("the study console script is not installed")
    # the delay counts from the end of the interpreter's own start (site, the .pth files of the venv):
    # a Ctrl-C before that is Python's, before any of rimroll's code; measured now, as loaded as the run
    start = time.perf_counter()
    subprocess.run([sys.executable, "-c", "pass"], check=True)
    python_starts = time.perf_counter() - start
    run = subprocess.Popen([script, "run", "fig8", "--quick", "--out", str(tmp_path / "o"), "--no-progress"],
                           stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    time.sleep(python_starts + delay)
    run.send_signal(signal.SIGINT)
    out, err = run.communicate(timeout=120)
    assert "Traceback" not in err and run.returncode in (0, 130), (run.returncode, err)
    if run.returncode == 130:
        assert len(err.strip().splitlines()) == 1 and "interrupted" in err, err


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
    p = subprocess.Popen(cmd, stderr=subprocess.PIPE, text=True, env=clean_probe_env())
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
                           capture_output=True, text=True, env=clean_probe_env(), timeout=300)
    assert again.returncode == 0, again.stderr


def test_a_sigterm_inside_an_import_is_delivered_after_it(monkeypatch):
    """The handler does not raise inside an import (numba's compiled extensions print the interrupt and
    turn it into ImportError): it sends SIGTERM again a moment later, and raises outside the import."""
    from rimroll.study import stopping

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
