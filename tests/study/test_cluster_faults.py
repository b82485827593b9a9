"""A cluster that fails a run: every wait has a bound and a one-line message.

Generated cases: the only worker of a ``--scheduler`` run killed (SIGKILL, with or without its
nanny) or frozen (SIGSTOP), before or after its first chunk, or the scheduler frozen; each run stops
within a bound of its ``--timeout`` with one line naming the scheduler, exit 2, and the chunks it finished kept. And
client-side TLS mistakes (generated from the settings a client can get wrong) are said as the
client's, not as "not a dask scheduler"; a ``scheduler_file`` that is no path is one error.

Schedulers and workers are subprocesses on 127.0.0.1; the runs use the test-only ``fanout-probe``
study (tests/helpers/fanout_probe.py).
"""

from __future__ import annotations

import contextlib
import itertools
import json
import os
import pathlib
import random
import signal
import socket
import subprocess
import sys
import threading
import time

import pytest

from rimroll.study import registry
from rimroll.study.registry import PLUGIN_ENV, UserError
from tests.helpers.paths import HELPERS
from tests.helpers.study_runs import cli, error_after_notices, parts_of, probe_env, run_probe

HERE = HELPERS
PROBE = str(HERE / "fanout_probe.py")
START_S = 90  # bound on a scheduler or a worker coming up, on a busy machine
TIMEOUT = 6  # the runs' --timeout [s]


def _env(**extra):
    env = {**os.environ, PLUGIN_ENV: PROBE, **extra}
    env.pop("FANOUT_PROBE_FAIL_MU", None)
    return env


@contextlib.contextmanager
def _scheduler(tmp_path):
    sfile = tmp_path / "scheduler.json"
    p = subprocess.Popen([sys.executable, "-m", "distributed.cli.dask_scheduler", "--host", "127.0.0.1", "--port", "0",
                          "--no-dashboard", "--scheduler-file", str(sfile)], env=_env(),
                         stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL, start_new_session=True)
    try:
        deadline = time.monotonic() + START_S
        address = None
        while address is None:
            with contextlib.suppress(OSError, ValueError, KeyError):
                address = json.loads(sfile.read_text())["address"]
            assert p.poll() is None and time.monotonic() < deadline, "the scheduler did not start"
            time.sleep(0.1)
        yield address, p
    finally:
        _stop(p)


def _stop(p: subprocess.Popen) -> None:
    with contextlib.suppress(ProcessLookupError, PermissionError):
        os.killpg(p.pid, signal.SIGCONT)
    if p.poll() is None:
        p.terminate()
    try:
        p.wait(timeout=15)
    except subprocess.TimeoutExpired:
        with contextlib.suppress(ProcessLookupError):
            os.killpg(p.pid, signal.SIGKILL)
        p.wait(timeout=15)


def _worker(address: str, nanny: bool) -> subprocess.Popen:
    """One single-threaded worker (with a nanny process above it when ``nanny``), in its own process
    group so that a test can kill or freeze both."""
    return subprocess.Popen([sys.executable, "-m", "distributed.cli.dask_worker", address, "--nthreads", "1",
                             "--no-dashboard", "--host", "127.0.0.1", *([] if nanny else ["--no-nanny"])],
                            env=_env(), stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL, start_new_session=True)


CASES = [*itertools.product(("SIGKILL", "SIGSTOP"), (False, True), (0, 1)), ("SIGSTOP-scheduler", False, 1)]
"""(signal to the worker's process group, or to the scheduler's; with a nanny; chunks finished before it)."""


def _case_id(case) -> str:
    how, nanny, after = case
    return f"{how}-{'nanny' if nanny else 'no_nanny'}-after{after}"


@pytest.mark.parametrize("case", [pytest.param(c, id=_case_id(c), marks=() if i == 0 else pytest.mark.slow)
                                  for i, c in enumerate(random.Random(42).sample(CASES[:8], 8) + CASES[8:])])
def test_a_run_whose_only_worker_dies_or_freezes_stops_in_one_line(tmp_path, case):
    how, nanny, after = case
    out = tmp_path / "out"
    log = tmp_path / "chunks.log"
    with _scheduler(tmp_path) as (address, scheduler):
        worker = _worker(address, nanny)
        try:
            run = subprocess.Popen([sys.executable, "-m", "rimroll.study", "run", "fanout-probe", "--out", str(out),
                                    "--scheduler", address, "--timeout", str(TIMEOUT), "--no-progress",
                                    "--set", "delay=0.3", "--set", "n_x=40", "--set", f"log={log}"],
                                   env=_env(PYTHONFAULTHANDLER="1"), stderr=subprocess.PIPE, text=True)
            deadline = time.monotonic() + START_S
            while not log.exists() or len(log.read_text().splitlines()) < max(after, 1):
                assert run.poll() is None and time.monotonic() < deadline, run.communicate(timeout=30)
                time.sleep(0.02)
            if after:  # the first part on disk too
                while not list(out.glob(".parts/*/chunk-*.npz")):
                    assert run.poll() is None and time.monotonic() < deadline, run.communicate(timeout=30)
                    time.sleep(0.02)
            target = scheduler if how.endswith("-scheduler") else worker
            os.killpg(target.pid, getattr(signal, how.split("-")[0]))
            t0 = time.monotonic()
            try:
                err = run.communicate(timeout=TIMEOUT * 6 + 60)[1]
            except subprocess.TimeoutExpired:  # a hang: the stacks of its threads (faulthandler) say where
                run.send_signal(signal.SIGABRT)
                pytest.fail(f"{case}: no end after {TIMEOUT * 6 + 60} s: {run.communicate(timeout=60)[1][-8000:]}")
            waited = time.monotonic() - t0
        finally:
            if run.poll() is None:
                run.kill()
                run.wait(timeout=30)
            _stop(worker)
    lines = [line for line in err.strip().splitlines()
             if ": dashboard of the cluster at " not in line and ": working, " not in line]
    assert run.returncode == 2 and "Traceback" not in err and len(lines) == 1, (case, run.returncode, err)
    assert lines[0].startswith("study: error: ") and address in lines[0] and "chunks saved" in lines[0], lines
    saved = len(list(out.glob(".parts/*/chunk-*.npz")))
    assert saved >= after and f"{saved} of 60 chunks saved" in lines[0]
    assert waited < TIMEOUT * 6 + 30, waited  # bounded by --timeout, with a machine's slack


# ---------------------------------------------------------------- client-side TLS mistakes

def _pem(directory: pathlib.Path) -> tuple[str, str]:
    cert, key = directory / "cert.pem", directory / "key.pem"
    subprocess.run(["openssl", "req", "-x509", "-newkey", "rsa:2048", "-nodes", "-keyout", str(key), "-out", str(cert),
                    "-days", "1", "-subj", "/CN=127.0.0.1", "-addext", "subjectAltName=IP:127.0.0.1"],
                   check=True, capture_output=True, timeout=60)
    return str(cert), str(key)


KEYS = {"ca": "distributed.comm.tls.ca-file", "cert": "distributed.comm.tls.client.cert",
        "key": "distributed.comm.tls.client.key"}


def _mistakes(cert: str, key: str, garbage: str, missing: str):
    """Every client configuration for a tls:// address made of each setting absent, missing, garbage
    or right, less the one that is right; and require-encryption over tcp://. Yields (address
    scheme, config, words the message must hold)."""
    options = {"ca": (None, missing, garbage, cert), "cert": (None, missing, garbage, cert),
               "key": (None, missing, garbage, key)}
    for ca, crt, k in itertools.product(*options.values()):
        if (ca, crt, k) in ((cert, cert, key), (cert, cert, None)):
            continue  # right (cert.pem holds no key: None is a mistake only for a cert without it -- below)
        config = {KEYS[name]: value for name, value in zip(("ca", "cert", "key"), (ca, crt, k)) if value}
        yield "tls", config, ["this client's TLS setting", "TLS settings"]
    yield "tls", {KEYS["ca"]: cert, KEYS["cert"]: cert}, ["cannot be loaded", "distributed.comm.tls.client.key"]
    yield "tcp", {"distributed.comm.require-encryption": True}, ["require-encryption", "tls://"]


@pytest.mark.skipif(not __import__("shutil").which("openssl"), reason="needs openssl to make a certificate")
def test_client_side_tls_mistakes_name_the_client_setting(tmp_path):
    import dask

    from rimroll.study import fanout

    cert, key = _pem(tmp_path)
    garbage = tmp_path / "garbage.pem"
    garbage.write_bytes(os.urandom(300))
    missing = str(tmp_path / "absent.pem")
    n = 0
    for scheme, config, words in _mistakes(cert, key, str(garbage), missing):
        address = f"{scheme}://127.0.0.1:1"
        with dask.config.set(config):
            problem = fanout.tls_problem(address)
            assert problem is not None and any(w in problem for w in words), (config, problem)
            assert "not a dask scheduler" not in problem and "\n" not in problem
            for path in {v for v in config.values() if isinstance(v, str) and v in (missing, str(garbage))}:
                if path == missing and "does not exist" in problem:
                    assert path in problem
            with pytest.raises(UserError, match="cannot connect to the dask scheduler at .*: "):
                with fanout.client(scheduler=address, timeout=2):
                    pass
        n += 1
    assert n >= 60
    with dask.config.set({KEYS["ca"]: cert, KEYS["cert"]: cert, KEYS["key"]: key}):
        assert fanout.tls_problem("tls://127.0.0.1:1") is None  # the right settings: nothing to say


@pytest.mark.parametrize("value", [5, 2.5, b"scheduler.json", ["a"], "", object()])
def test_a_scheduler_file_or_address_that_is_no_path_is_one_error(tmp_path, value, probe_study):
    import rimroll

    with pytest.raises(UserError, match=r"^scheduler_file must be a path"):
        rimroll.run("fanout-probe", out=tmp_path, scheduler_file=value)
    if not isinstance(value, str):
        with pytest.raises(UserError, match=r"^scheduler must be an address"):
            rimroll.run("fanout-probe", out=tmp_path, scheduler=value)


@pytest.fixture
def listener():
    """A TCP listener on 127.0.0.1: 'silent' accepts and never answers; 'http' answers like a web server."""
    servers = []

    def start(kind):
        s = socket.socket()
        s.bind(("127.0.0.1", 0))
        s.listen(8)
        servers.append(s)
        conns = []

        def serve():
            while True:
                try:
                    c, _ = s.accept()
                except OSError:
                    return
                conns.append(c)
                if kind == "http":
                    try:
                        c.recv(100)
                        c.sendall(b"HTTP/1.1 400 Bad Request\r\nContent-Length: 0\r\n\r\n" * 200)
                    except OSError:
                        pass

        threading.Thread(target=serve, daemon=True).start()
        return f"tcp://127.0.0.1:{s.getsockname()[1]}"

    yield start
    for s in servers:
        s.close()


@pytest.mark.parametrize("kind, expect", [("silent", "within 2 s"), ("http", "is not a dask scheduler")])
def test_scheduler_that_is_not_dask_is_one_line(probe, tmp_path, listener, kind, expect):
    address = listener(kind)
    t0 = time.monotonic()
    run = cli("run", "fanout-probe", "--out", str(tmp_path), "--no-progress", "--scheduler", address,
              "--timeout", "2", timeout=60)
    assert run.returncode == 2 and time.monotonic() - t0 < 60
    error_after_notices(run.stderr, expect)
    assert not (tmp_path / ".parts").exists()


def test_scheduler_address_is_checked_without_connecting(probe, tmp_path, capsys):
    for bad in ("tcp://10.255.255.1:99999", "not an address", "http://127.0.0.1:80"):
        assert run_probe(tmp_path, "--scheduler", bad) == 2
        error_after_notices(capsys.readouterr().err, "--scheduler")


def test_scheduler_without_workers(probe, tmp_path, capsys):
    from distributed import LocalCluster

    with LocalCluster(n_workers=0, dashboard_address=None) as cluster:
        assert run_probe(tmp_path, "--scheduler", cluster.scheduler_address, "--timeout", "2") == 2
    error_after_notices(capsys.readouterr().err, f"no workers at {cluster.scheduler_address} after 2 s")


def test_last_worker_lost_mid_run(tmp_path):
    from distributed import Client, LocalCluster

    out = tmp_path / "out"
    with LocalCluster(n_workers=0, dashboard_address=None) as cluster:
        worker = subprocess.Popen([sys.executable, "-m", "distributed.cli.dask_worker", cluster.scheduler_address,
                                   "--no-nanny", "--nthreads", "1", "--no-dashboard"], env=probe_env(),
                                  stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
        try:
            with Client(cluster) as c:
                c.wait_for_workers(1, timeout=60)
            run = subprocess.Popen([sys.executable, "-m", "rimroll.study", "run", "fanout-probe", "--out", str(out),
                                    "--no-progress", "--scheduler", cluster.scheduler_address, "--timeout", "3",
                                    "--set", "delay=0.3"], env=probe_env(), stdout=subprocess.PIPE,
                                   stderr=subprocess.PIPE, text=True)
            deadline = time.monotonic() + 60
            while len(parts_of(out)) < 2:
                assert run.poll() is None and time.monotonic() < deadline, run.communicate()
                time.sleep(0.05)
            worker.send_signal(signal.SIGKILL)
            worker.wait(timeout=10)
            _, err = run.communicate(timeout=90)
        finally:
            worker.kill()
    assert run.returncode == 2
    error_after_notices(err, "worker lost", "chunks saved", "rerun")
    assert len(parts_of(out)) >= 2 and not list((out / ".parts").glob("*.lock"))


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
