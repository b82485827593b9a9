"""Runs on a cluster: workers are checked (a worker with other code refuses the chunks),
a scheduler file, a TLS scheduler with dask's Security, GPU workers on device 0 of what they see.

Every scheduler and worker here is a subprocess on 127.0.0.1, started with bounded waits and
stopped by the fixture; the runs use the test-only ``fanout-probe`` study (tests/helpers/fanout_probe.py).
"""

from __future__ import annotations

import contextlib
import json
import os
import pathlib
import re
import shutil
import subprocess
import sys
import time

import numpy as np
import pytest
import xarray as xr

from rimroll.study.registry import PLUGIN_ENV
from tests.helpers.paths import HELPERS

HERE = HELPERS
PROBE = str(HERE / "fanout_probe.py")
PRELOAD = str(HERE / "other_code_preload.py")
START_S = 60  # bound on a scheduler or worker coming up


def _env(**extra):
    env = {**os.environ, PLUGIN_ENV: PROBE, **extra}
    env.pop("FANOUT_PROBE_FAIL_MU", None)
    return env


def _wait_for(path: pathlib.Path, procs) -> dict:
    deadline = time.monotonic() + START_S
    while True:
        with contextlib.suppress(OSError, ValueError):
            return json.loads(path.read_text())
        for p in procs:
            assert p.poll() is None, p.communicate(timeout=10)
        assert time.monotonic() < deadline, "the scheduler did not write its file"
        time.sleep(0.1)


@contextlib.contextmanager
def cluster(tmp_path, workers=({},), tls=(), scheduler_env=None):
    """A scheduler and workers on 127.0.0.1 (subprocesses); yields the scheduler file. ``workers``:
    one dict per worker of extra environment, ``"preload"`` a module to preload; ``tls``: the
    command-line TLS options of scheduler and workers."""
    sfile = tmp_path / "scheduler.json"
    procs = []
    try:
        procs.append(subprocess.Popen(
            [sys.executable, "-m", "distributed.cli.dask_scheduler", "--host", "127.0.0.1", "--port", "0",
             "--no-dashboard", "--scheduler-file", str(sfile), *(["--protocol", "tls", *tls] if tls else [])],
            env=_env(**(scheduler_env or {})), stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True))
        _wait_for(sfile, procs)
        for extra in workers:
            extra = dict(extra)
            preload = extra.pop("preload", None)
            procs.append(subprocess.Popen(
                [sys.executable, "-m", "distributed.cli.dask_worker", "--scheduler-file", str(sfile), "--no-nanny",
                 "--nthreads", "1", "--no-dashboard", "--host", "127.0.0.1", *tls,
                 *(["--preload", preload] if preload else [])],
                env=_env(**extra), stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True))
        yield sfile
    finally:
        for p in reversed(procs):
            p.terminate()
        for p in reversed(procs):
            try:
                p.wait(timeout=10)
            except subprocess.TimeoutExpired:
                p.kill()
                p.wait(timeout=10)


def _study(*args, env=None, timeout=180):
    return subprocess.run([sys.executable, "-m", "rimroll.study", *args], capture_output=True, text=True,
                          timeout=timeout, env=env or _env())


_HEARTBEAT = re.compile(r"study: [\w-]+: working, \d+ of \d+ chunks done after [\w .]+ "
                        r"\(Ctrl-C stops, a rerun resumes\)$")
"""A line of ``study.run_notices.heartbeat``: said when no chunk finished for 2 s, on a slow machine too."""


def _errors(err: str) -> list[str]:
    return [line for line in err.strip().splitlines() if ": dashboard of the cluster at " not in line]


def test_a_scheduler_file_reaches_the_cluster_from_the_command_and_from_python(tmp_path, probe_study):
    """``study run --scheduler-file`` (its dashboard link printed) and ``rimroll.run(client=...)`` on one
    cluster of two workers."""
    from distributed import Client

    import rimroll

    with cluster(tmp_path, workers=[{}, {}]) as sfile:
        run = _study("run", "fanout-probe", "--out", str(tmp_path / "out"), "--no-progress",
                     "--scheduler-file", str(sfile), "--timeout", "30")
        with Client(scheduler_file=str(sfile), timeout=30) as c:
            ds = rimroll.run("fanout-probe", client=c, mu=[0.5, 1], v_throw=1)
    assert run.returncode == 0, run.stderr
    assert "fanout-probe: dashboard of the cluster at http://127.0.0.1:" in run.stderr  # --no-dashboard: none served
    with xr.open_dataset(tmp_path / "out" / "fanout-probe.nc") as whole:
        assert whole.sizes == {"mu": 3, "v_throw": 2, "x": 8, "y": 3}
        np.testing.assert_array_equal(ds["f"].values, whole["f"].sel(mu=[0.5, 1.0], v_throw=1.0).values)


def test_a_scheduler_file_that_never_appears_is_one_line(tmp_path):
    run = _study("run", "fanout-probe", "--out", str(tmp_path), "--scheduler-file", str(tmp_path / "none.json"),
                 "--timeout", "1")
    assert run.returncode == 2 and _errors(run.stderr) == [f"study: error: no scheduler file at "
                                                          f"{tmp_path / 'none.json'} after 1 s"]
    both = _study("run", "fanout-probe", "--out", str(tmp_path), "--scheduler-file", "x", "--scheduler",
                  "tcp://127.0.0.1:1")
    assert both.returncode == 2 and "not both" in both.stderr


def test_a_worker_with_other_code_refuses_the_chunks(tmp_path):
    """The client's code digest travels with every chunk; a worker whose own digest differs (here a
    worker process whose preload patches study.plan.code_digest, as another checkout on its path would)
    refuses the chunk in one line naming both digests, and nothing of it is saved."""
    from rimroll.study import plan, registry

    mine = plan.code_digest(registry.get("fig8"))
    with cluster(tmp_path, workers=[{"preload": PRELOAD}]) as sfile:
        run = _study("run", "fig8", "--quick", "--out", str(tmp_path / "out"), "--no-progress",
                     "--scheduler-file", str(sfile), "--timeout", "30")
    # on a busy machine the run may say it is still working before the refusal comes: those notices
    # (run_notices.heartbeat) are set aside, every other line still counts
    lines = [line for line in _errors(run.stderr) if not _HEARTBEAT.match(line)]
    assert run.returncode == 2 and len(lines) == 1, run.stderr
    assert lines[0].startswith("study: error: worker tcp://127.0.0.1:") and "refuses chunks of fig8" in lines[0]
    assert f"its code digest {mine[::-1][:16]} differs from the client's {mine[:16]}" in lines[0]
    assert not (tmp_path / "out" / "fig8.nc").exists()
    assert not list((tmp_path / "out").glob(".parts/*/chunk-*.npz"))


def _certificate(directory: pathlib.Path) -> tuple[str, str]:
    """A self-signed certificate and key for 127.0.0.1, made with openssl (valid for one day)."""
    cert, key = directory / "cert.pem", directory / "key.pem"
    subprocess.run(["openssl", "req", "-x509", "-newkey", "rsa:2048", "-nodes", "-keyout", str(key), "-out", str(cert),
                    "-days", "1", "-subj", "/CN=127.0.0.1", "-addext", "subjectAltName=IP:127.0.0.1"],
                   check=True, capture_output=True, timeout=60)
    return str(cert), str(key)


@pytest.mark.skipif(shutil.which("openssl") is None, reason="needs the openssl command to make a certificate")
def test_a_tls_scheduler_is_reached_with_the_security_of_the_dask_configuration(tmp_path):
    cert, key = _certificate(tmp_path)
    tls = ["--tls-ca-file", cert, "--tls-cert", cert, "--tls-key", key]
    config = {"DASK_DISTRIBUTED__COMM__TLS__CA_FILE": cert, "DASK_DISTRIBUTED__COMM__TLS__CLIENT__CERT": cert,
              "DASK_DISTRIBUTED__COMM__TLS__CLIENT__KEY": key, "DASK_DISTRIBUTED__COMM__REQUIRE_ENCRYPTION": "True"}
    with cluster(tmp_path, tls=tls) as sfile:
        address = json.loads(sfile.read_text())["address"]
        assert address.startswith("tls://127.0.0.1:")
        plain = _study("run", "fanout-probe", "--out", str(tmp_path / "plain"), "--scheduler", address,
                       "--timeout", "5")
        run = _study("run", "fanout-probe", "--out", str(tmp_path / "out"), "--no-progress", "--scheduler", address,
                     "--timeout", "30", env=_env(**config))
    assert plain.returncode == 2 and _errors(plain.stderr)[0].startswith("study: error:")  # no certificate: refused
    assert run.returncode == 0, run.stderr
    assert (tmp_path / "out" / "fanout-probe.nc").is_file()


# ---------------------------------------------------------------- GPU workers (no GPU needed)

def test_gpu_workers_take_device_0_of_the_devices_the_cluster_gave_them(monkeypatch):
    """dask-cuda rotates CUDA_VISIBLE_DEVICES per worker (worker i sees i, i+1, ..., 0, ...): device 0 of
    what each worker sees is its own GPU, whatever its name; rimroll's own local workers (all seeing
    the same devices) go by their number."""
    from rimroll.solver.engine.backends import DEVICE_ENV
    from rimroll.study.gpu_workers import OneGPUPerWorker, device_index

    for i in range(4):
        rotated = {"CUDA_VISIBLE_DEVICES": ",".join(str((i + k) % 4) for k in range(4))}
        assert device_index(i, local=False, environ=rotated) == 0
        assert device_index(f"tcp://10.0.0.{i}:1234", local=False, environ=rotated) == 0
        assert device_index(i, local=True, environ={"CUDA_VISIBLE_DEVICES": "0,1,2,3"}) == i
    assert device_index(5, local=False, environ={}, count=4) == 1  # no devices chosen by the cluster: by number
    assert device_index("worker-a", local=False, environ={}, count=4) == 0

    class Worker:
        name = 3

    monkeypatch.setenv("CUDA_VISIBLE_DEVICES", "3,0,1,2")
    monkeypatch.delenv(DEVICE_ENV, raising=False)
    OneGPUPerWorker().setup(Worker())
    assert os.environ[DEVICE_ENV] == "0"
    OneGPUPerWorker(local=True).setup(Worker())
    assert os.environ[DEVICE_ENV] == "3"
