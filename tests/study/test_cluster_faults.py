"""A cluster that fails a run (issue 42, "Cluster"): every wait has a bound and a one-line message.

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
import subprocess
import sys
import time

import pytest

from rimroll.study.registry import PLUGIN_ENV, UserError
from tests.helpers.paths import HELPERS

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
