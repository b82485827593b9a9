"""Runs you can trust (issue 11): no stale or mixed result, no hang, every failure one line.

Most checks use the test-only ``fanout-probe`` study (``tests/helpers/fanout_probe.py``, loaded through
``RIMROLL_STUDY_MODULES``). The hang checks use a short ``--timeout`` against listeners on
127.0.0.1 and a dask scheduler without workers; no test contacts any other address.
"""

from __future__ import annotations

import errno
import os
import pathlib
import signal
import socket
import subprocess
import sys
import threading
import time

import numpy as np
import pytest
import xarray as xr

from rimroll.study import registry
from rimroll.study.cli import main, natural_order
from rimroll.study.parts import PartStore
from rimroll.study.plan import make_plan
from rimroll.study.registry import PLUGIN_ENV
from tests.helpers.paths import HELPERS, ROOT

PROBE = str(HELPERS / "fanout_probe.py")
N_PROBE = 12  # chunks of the probe at its defaults: mu (3) x v_throw (2) x x (2 chunks)


@pytest.fixture
def probe(monkeypatch):
    monkeypatch.setenv(PLUGIN_ENV, PROBE)
    monkeypatch.delenv("FANOUT_PROBE_FAIL_MU", raising=False)
    return registry.get("fanout-probe")


def _env(**extra):
    return {**os.environ, PLUGIN_ENV: PROBE, **extra}


def _run(out, *extra, name="fanout-probe"):
    return main(["run", name, "--out", str(out), "--no-progress", *extra])


def _one_line_error(err: str, *needles):
    """One error line; before it, a run on a cluster may have given the link to its dashboard, and a
    run waiting on a chunk may have said it is working (notices)."""
    lines = [line for line in err.strip().splitlines()
             if ": dashboard of the cluster at " not in line and ": working, " not in line]
    assert len(lines) == 1 and lines[0].startswith("study: error:"), err
    assert "Traceback" not in err
    for needle in needles:
        assert needle in lines[0], (needle, lines[0])


def _cli(*args, env=None, timeout=120, **kw):
    return subprocess.run([sys.executable, "-m", "rimroll.study", *args], capture_output=True, text=True,
                          timeout=timeout, env=env or _env(), **kw)


def _parts(out):
    return sorted((pathlib.Path(out) / ".parts").glob("*/chunk-*.npz"))


def _data(path):
    with xr.open_dataset(path) as ds:
        return {k: ds[k].values.copy() for k in ds.data_vars}


# ================================================================ 1. stale results
def test_result_of_other_inputs_is_not_reused(tmp_path, capsys):
    nc = tmp_path / "fig8.nc"
    assert main(["run", "fig8", "--quick", "--out", str(tmp_path), "--no-progress"]) == 0
    capsys.readouterr()
    assert main(["run", "fig8", "--quick", "--set", "mu=0.1", "--out", str(tmp_path), "--no-progress"]) == 2
    _one_line_error(capsys.readouterr().err, "param_mu 1.0 in the file, 0.1 requested", "--force", "--out")
    with xr.open_dataset(nc) as ds:
        assert ds.attrs["param_mu"] == 1.0
    # a full run after a --quick one differs in the grid
    assert main(["run", "fig8", "--out", str(tmp_path), "--no-progress", "--set", "n_omega30=40"]) == 2
    _one_line_error(capsys.readouterr().err, "setting_n_beta0 121 in the file, 721 requested")
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
    assert _run(tmp_path) == 0
    nc = tmp_path / "fanout-probe.nc"
    with xr.open_dataset(nc) as ds:
        edited = ds.load()
    edited.attrs.pop("data_sha256")
    edited["f"] = edited["f"] * 2
    edited.to_netcdf(tmp_path / "edited.nc")
    os.replace(tmp_path / "edited.nc", nc)
    capsys.readouterr()
    assert _run(tmp_path) == 2
    _one_line_error(capsys.readouterr().err, "no data_sha256", "--force")
    with xr.open_dataset(nc) as ds:
        np.testing.assert_array_equal(ds["f"].values, edited["f"].values)
    assert _run(tmp_path, "--force") == 0
    with xr.open_dataset(nc) as ds:
        assert "data_sha256" in ds.attrs


def test_truncated_result_is_recomputed(probe, tmp_path, capsys):
    assert _run(tmp_path) == 0
    nc = tmp_path / "fanout-probe.nc"
    good = _data(nc)
    nc.write_bytes(nc.read_bytes()[: nc.stat().st_size // 2])
    capsys.readouterr()
    assert _run(tmp_path) == 0
    captured = capsys.readouterr()
    assert "not a readable result" in captured.err and "wrote" in captured.out
    for k, v in _data(nc).items():
        np.testing.assert_array_equal(v, good[k])


# ================================================================ 2. one lock per output file
def test_lock_covers_the_output_file_whatever_the_inputs(probe, tmp_path, capsys):
    import fcntl

    other = make_plan(probe, sets=["v_throw=7"])  # a run of other inputs holds the output's lock
    store = PartStore(tmp_path, "fanout-probe", other.fingerprint)
    store.root.mkdir(parents=True)
    with open(store.lock_path, "w") as held:
        fcntl.flock(held, fcntl.LOCK_EX | fcntl.LOCK_NB)
        assert _run(tmp_path) == 2
    _one_line_error(capsys.readouterr().err, "in progress", str(tmp_path / "fanout-probe.nc"))
    assert not (tmp_path / "fanout-probe.nc").exists()


def test_concurrent_runs_of_different_inputs_never_both_write(tmp_path):
    out = tmp_path / "out"
    cmds = [["run", "fanout-probe", "--out", str(out), "--no-progress", "--workers", "1", "--set", "delay=0.2",
             "--set", f"v_throw={v}"] for v in (1.5, 2.5)]
    procs = [subprocess.Popen([sys.executable, "-m", "rimroll.study", *c], env=_env(), stdout=subprocess.PIPE,
                              stderr=subprocess.PIPE, text=True) for c in cmds]
    results = [(p.wait(timeout=120), *p.communicate()) for p in procs]
    assert sorted(r[0] for r in results) == [0, 2], results
    for rc, out_text, err in results:  # the other: in progress, or (if it came later) a file of other inputs
        if rc == 2:
            _one_line_error(err)
            assert "in progress" in err or "holds another run" in err
        else:
            winner = cmds[results.index((rc, out_text, err))]
    with xr.open_dataset(out / "fanout-probe.nc") as ds:
        assert f"v_throw={ds.attrs['setting_v_throw']}" == winner[-1]


# ================================================================ 3, 7. parts carry their identity; damage recomputed
def _failed_run_with_parts(probe, out, log):
    os.environ["FANOUT_PROBE_FAIL_MU"] = "2.0"
    try:
        with pytest.raises(RuntimeError, match="probe asked to fail"):
            _run(out, "--set", f"log={log}", "--workers", "1")
    finally:
        del os.environ["FANOUT_PROBE_FAIL_MU"]
    plan = make_plan(probe, sets=[f"log={log}"])
    store = PartStore(out, "fanout-probe", plan.fingerprint)
    kept = sorted(int(p.stem.split("-")[1]) for p in store.dir.glob("chunk-*.npz"))
    assert len(kept) >= 2
    return plan, store, kept


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
    assert _run(tmp_path / "out", "--set", f"log={log}", "--workers", "1") == 0
    assert _run(tmp_path / "clean", "--set", f"log={tmp_path / 'log2'}") == 0
    clean = _data(tmp_path / "clean" / "fanout-probe.nc")
    for k, v in _data(tmp_path / "out" / "fanout-probe.nc").items():
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
    assert _run(tmp_path / "out", "--set", f"log={log}", "--workers", "1") == 0
    assert len(log.read_text().splitlines()) - n0 == N_PROBE - len(kept) + 1


# ================================================================ 4. verify says what it compared
@pytest.fixture(scope="module")
def fig8_full(tmp_path_factory):
    """fig8 on the reference's sub-grid at default settings (every slice point, cheap)."""
    from rimroll.study import reference

    path = tmp_path_factory.mktemp("verify8") / "fig8.nc"
    reference.recompute("fig8", workers=1).to_netcdf(path)
    return path


@pytest.mark.parametrize("drop", [["region"], ["region", "omega20"]])
def test_verify_fails_when_a_variable_is_missing(fig8_full, tmp_path, capsys, drop):
    with xr.open_dataset(fig8_full) as ds:
        ds.load().drop_vars(drop).to_netcdf(tmp_path / "fig8.nc")
    # not a result of fig8 at all (issue 28: one reader validates first): one line, exit 2, not a comparison
    assert main(["verify", str(tmp_path / "fig8.nc")]) == 2
    _one_line_error(capsys.readouterr().err, f"lacks the variable(s) {', '.join(drop)} of study fig8")


def test_verify_states_coverage_and_fails_below_minimum(fig8_full, quick_results, tmp_path, capsys):
    from rimroll.study import reference
    from rimroll.study.compare import MIN_COVERAGE

    assert main(["verify", str(fig8_full)]) == 0
    assert "coverage: 9680 of the reference's 9680 points compared (100.0%" in capsys.readouterr().out
    default_only = tmp_path / "default-slice"  # without the quick slice, a quick grid shares 2 corners
    default_only.mkdir()
    (default_only / "fig8.nc").write_bytes(reference.reference_path("fig8").read_bytes())
    assert main(["verify", str(quick_results / "fig8.nc"), "--reference", str(default_only)]) == 1
    out = capsys.readouterr().out
    assert "FAIL coverage: 2 of the reference's 9680 points" in out and f"needed {100 * MIN_COVERAGE:.0f}%" in out


# ================================================================ 5. slices are package data
def test_slices_are_package_data_found_with_importlib(monkeypatch):
    import importlib.resources

    import tomllib

    from rimroll.study import reference

    monkeypatch.delenv(reference.ENV_DIR, raising=False)
    packaged = pathlib.Path(str(importlib.resources.files("rimroll.study") / "reference_slices"))
    assert reference.reference_dir() == packaged
    assert {p.stem for p in packaged.glob("*.nc")} == set(reference.specs())
    assert {p.stem for p in (packaged / "quick").glob("*.nc")} == set(reference.specs())
    root = ROOT
    config = tomllib.loads((root / "pyproject.toml").read_text())
    for pattern in ("reference_slices/*.nc", "reference_slices/quick/*.nc"):
        assert pattern in config["tool"]["setuptools"]["package-data"]["rimroll.study"]


def test_reference_build_never_writes_an_installed_package(monkeypatch, tmp_path, capsys):
    from rimroll.study import reference

    monkeypatch.setattr(reference, "checkout_dir", lambda: None)  # as after pip install
    monkeypatch.delenv(reference.ENV_DIR, raising=False)
    before = {p: p.stat().st_mtime_ns for p in reference.packaged_dir().glob("**/*.nc")}
    assert main(["reference", "--build", "--only", "fig9", "--no-progress"]) == 2
    _one_line_error(capsys.readouterr().err, "needs --out DIR")
    assert {p: p.stat().st_mtime_ns for p in reference.packaged_dir().glob("**/*.nc")} == before


@pytest.mark.slow
def test_verify_after_pip_install(tmp_path):
    """pip install . into a throwaway venv (dependencies from the running interpreter), then verify
    a fig8 result from another directory with the packaged slices."""
    import sysconfig

    root = ROOT
    src = tmp_path / "src"
    files = subprocess.run(["git", "ls-files", "-co", "--exclude-standard"], cwd=root, capture_output=True,
                           text=True, check=True).stdout.split()
    for f in files:
        if (root / f).is_file():
            (src / f).parent.mkdir(parents=True, exist_ok=True)
            (src / f).write_bytes((root / f).read_bytes())
    venv = tmp_path / "venv"
    subprocess.run([sys.executable, "-m", "venv", str(venv)], check=True)
    purelib = "import sysconfig; print(sysconfig.get_paths()['purelib'])"
    site = subprocess.run([str(venv / "bin" / "python"), "-c", purelib],
                          capture_output=True, text=True, check=True).stdout.strip()
    pathlib.Path(site, "zz_deps.pth").write_text(sysconfig.get_paths()["purelib"] + "\n")
    install = subprocess.run([str(venv / "bin" / "pip"), "install", "-q", "--no-deps", str(src)],
                             capture_output=True, text=True, timeout=600)
    if install.returncode != 0:
        pytest.skip(f"pip install . impossible here: {install.stderr.strip().splitlines()[-1:]}")
    env = {k: v for k, v in os.environ.items() if k not in ("PYTHONPATH", "RIMROLL_REFERENCE_DIR")}
    study = str(venv / "bin" / "study")
    run = subprocess.run([study, "run", "fig8", "--out", str(tmp_path / "res"), "--no-progress"], cwd=tmp_path,
                         env=env, capture_output=True, text=True, timeout=600)
    assert run.returncode == 0, run.stderr
    verify = subprocess.run([study, "verify", str(tmp_path / "res" / "fig8.nc")], cwd=tmp_path, env=env,
                            capture_output=True, text=True, timeout=600)
    assert verify.returncode == 0 and "site-packages/rimroll/study/reference_slices/fig8.nc" in verify.stdout, verify
    build = subprocess.run([study, "reference", "--build", "--only", "fig9"], cwd=tmp_path, env=env,
                           capture_output=True, text=True, timeout=600)
    assert build.returncode == 2 and "needs --out" in build.stderr
    # the studies come from the installed entry points; a --quick run verifies against the quick slice
    listed = subprocess.run([study, "list"], cwd=tmp_path, env=env, capture_output=True, text=True, timeout=600)
    assert [line.split()[0] for line in listed.stdout.splitlines()] == natural_order(registry.names())
    quick = subprocess.run([study, "run", "fig8", "--quick", "--out", str(tmp_path / "quick"), "--no-progress"],
                           cwd=tmp_path, env=env, capture_output=True, text=True, timeout=600)
    assert quick.returncode == 0, quick.stderr
    verify = subprocess.run([study, "verify", str(tmp_path / "quick" / "fig8.nc")], cwd=tmp_path, env=env,
                            capture_output=True, text=True, timeout=600)
    shipped = "site-packages/rimroll/study/reference_slices/quick/fig8.nc"
    assert verify.returncode == 0 and shipped in verify.stdout, verify


# ================================================================ 6. a cube with every swept setting scalar
def test_realisable_cube_with_every_swept_setting_scalar(tmp_path):
    sets = ["--quick", "--set", "mu=1", "--set", "v_throw=5", "--set", "j=0.5", "--set", "rho_over_R=0.5",
            "--set", "n_beta0=24", "--set", "n_omega30=16"]
    assert _run(tmp_path, *sets, name="realisable-cube") == 0
    with xr.open_dataset(tmp_path / "realisable-cube.nc") as ds:
        assert ds.area_A.shape == () and ds.region.dims == ("beta0", "omega30")
        assert float(ds.area_A) > 0 and int((ds.region == 1).sum()) > 0


# ================================================================ 8. bounded waits
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
    run = _cli("run", "fanout-probe", "--out", str(tmp_path), "--no-progress", "--scheduler", address,
               "--timeout", "2", timeout=60)
    assert run.returncode == 2 and time.monotonic() - t0 < 60
    _one_line_error(run.stderr, expect)
    assert not (tmp_path / ".parts").exists()


def test_scheduler_address_is_checked_without_connecting(probe, tmp_path, capsys):
    for bad in ("tcp://10.255.255.1:99999", "not an address", "http://127.0.0.1:80"):
        assert _run(tmp_path, "--scheduler", bad) == 2
        _one_line_error(capsys.readouterr().err, "--scheduler")


def test_scheduler_without_workers(probe, tmp_path, capsys):
    from distributed import LocalCluster

    with LocalCluster(n_workers=0, dashboard_address=None) as cluster:
        assert _run(tmp_path, "--scheduler", cluster.scheduler_address, "--timeout", "2") == 2
    _one_line_error(capsys.readouterr().err, f"no workers at {cluster.scheduler_address} after 2 s")


def test_last_worker_lost_mid_run(tmp_path):
    from distributed import Client, LocalCluster

    out = tmp_path / "out"
    with LocalCluster(n_workers=0, dashboard_address=None) as cluster:
        worker = subprocess.Popen([sys.executable, "-m", "distributed.cli.dask_worker", cluster.scheduler_address,
                                   "--no-nanny", "--nthreads", "1", "--no-dashboard"], env=_env(),
                                  stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
        try:
            with Client(cluster) as c:
                c.wait_for_workers(1, timeout=60)
            run = subprocess.Popen([sys.executable, "-m", "rimroll.study", "run", "fanout-probe", "--out", str(out),
                                    "--no-progress", "--scheduler", cluster.scheduler_address, "--timeout", "3",
                                    "--set", "delay=0.3"], env=_env(), stdout=subprocess.PIPE,
                                   stderr=subprocess.PIPE, text=True)
            deadline = time.monotonic() + 60
            while len(_parts(out)) < 2:
                assert run.poll() is None and time.monotonic() < deadline, run.communicate()
                time.sleep(0.05)
            worker.send_signal(signal.SIGKILL)
            worker.wait(timeout=10)
            _, err = run.communicate(timeout=90)
        finally:
            worker.kill()
    assert run.returncode == 2
    _one_line_error(err, "worker lost", "chunks saved", "rerun")
    assert len(_parts(out)) >= 2 and not list((out / ".parts").glob("*.lock"))


# ================================================================ 9. sizes validated, plan printed
def test_absurd_sizes_are_refused_at_once(probe, tmp_path, capsys):
    cases = [(["--workers", "1000000000000"], "--workers must be between 1 and"),
             (["--set", "mu=0.1:10:10000000"], "at most 100000 values"),
             (["--set", "mu=0.1:10:1000", "--set", "v_throw=1:2:1000"], "chunks"),
             (["--set", "n_x=1000000000"], "n_x")]
    for extra, expect in cases:
        t0 = time.monotonic()
        assert _run(tmp_path, *extra) == 2
        _one_line_error(capsys.readouterr().err, expect)
        assert time.monotonic() - t0 < 30, extra
    assert not list(tmp_path.iterdir())


def test_long_run_prints_its_plan(probe, tmp_path, capsys):
    assert _run(tmp_path, "--set", "mu=0.1:1:50", "--set", "n_x=4") == 0
    err = capsys.readouterr().err
    assert "100 of 100 chunks to compute" in err and "Ctrl-C" in err


# ================================================================ 10. one line, exit 2, nothing lost
@pytest.mark.parametrize("argv, expect", [
    (["outcome-cube", "--quick", "--set", "rtol=0"], "rtol"),
    (["outcome-cube", "--quick", "--set", "t_max=-1"], "t_max"),
    (["outcome-cube", "--quick", "--set", "atol=nan"], "atol"),
    (["fig11", "--quick", "--set", "method=rk4"], "dop853, dp5"),
    (["fig11", "--quick", "--set", "mu_slip=-1"], "mu_slip"),
    (["fig11", "--quick", "--set", "k_dissipation=-1"], "k_dissipation"),
    (["invariants", "--quick", "--set", "seed=-1"], "seed"),
    (["fig11", "--quick", "--set", "omega1_max=1e308"], "omega1_max"),
    (["fig11", "--quick", "--set", "mu=2"], "does not use 'mu'"),
    (["fig5", "--quick", "--set", "mu=2"], "does not use 'mu'"),
    (["fig13", "--quick", "--set", "k_r=0.1"], "does not use 'k_r'"),
])
def test_bad_settings_refused_before_any_work(tmp_path, capsys, argv, expect):
    assert main(["run", *argv, "--out", str(tmp_path / "o"), "--no-progress"]) == 2
    _one_line_error(capsys.readouterr().err, expect)
    assert not (tmp_path / "o").exists()


def test_bad_out_is_one_line(probe, tmp_path, capsys):
    (tmp_path / "file").write_text("x")
    assert _run(tmp_path / "file") == 2
    _one_line_error(capsys.readouterr().err, "is not a directory")
    assert _run("/proc/rimroll-test") == 2
    _one_line_error(capsys.readouterr().err, "cannot write into --out /proc/rimroll-test")
    if os.geteuid() != 0:  # root writes anywhere
        ro = tmp_path / "ro"
        ro.mkdir()
        ro.chmod(0o500)
        try:
            assert _run(ro) == 2
            _one_line_error(capsys.readouterr().err, "cannot write into --out")
        finally:
            ro.chmod(0o700)


def test_disk_full_mid_run_says_what_was_saved(probe, tmp_path, capsys, monkeypatch):
    real = PartStore.save
    calls = []

    def save(self, k, arrays):
        calls.append(k)
        if len(calls) > 3:
            raise OSError(errno.ENOSPC, "No space left on device", str(self.path(k)))
        return real(self, k, arrays)

    monkeypatch.setattr(PartStore, "save", save)
    assert _run(tmp_path, "--workers", "1") == 2
    _one_line_error(capsys.readouterr().err, "No space left on device", f"3 of {N_PROBE} chunks saved", "rerun")
    assert len(_parts(tmp_path)) == 3 and not list((tmp_path / ".parts").glob("*.lock"))
    monkeypatch.setattr(PartStore, "save", real)
    assert _run(tmp_path) == 0 and f"3 of {N_PROBE} chunks resumed" in capsys.readouterr().out


def test_file_size_limit_mid_run_is_one_line(tmp_path):
    import resource

    def limit():
        resource.setrlimit(resource.RLIMIT_FSIZE, (16_000, 16_000))  # parts fit, the assembled file does not

    run = _cli("run", "fanout-probe", "--out", str(tmp_path), "--no-progress", "--set", "n_x=60",
               preexec_fn=limit)
    assert run.returncode == 2, run.stderr
    _one_line_error(run.stderr, "file size limit (ulimit -f) 16000 bytes", "chunks saved")
    assert not (tmp_path / "fanout-probe.nc").exists()
    rerun = _cli("run", "fanout-probe", "--out", str(tmp_path), "--no-progress", "--set", "n_x=60")
    assert rerun.returncode == 0 and "chunks resumed" in rerun.stdout, rerun.stderr


@pytest.mark.parametrize("sig, status, word", [(signal.SIGINT, 130, "study: interrupted;"),
                                               (signal.SIGTERM, 143, "study: terminated (SIGTERM);")])
def test_ctrl_c_says_what_was_saved(tmp_path, sig, status, word):
    """Ctrl-C, and SIGTERM as ``timeout`` or a batch system sends it (it killed the run with no word and
    left the lock file), stop a run in one line saying what was saved; the rerun resumes."""
    out = tmp_path / "out"
    proc = subprocess.Popen([sys.executable, "-m", "rimroll.study", "run", "fanout-probe", "--out", str(out),
                             "--no-progress", "--workers", "1", "--set", "delay=0.3"], env=_env(),
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    deadline = time.monotonic() + 60
    while len(_parts(out)) < 2:
        assert proc.poll() is None and time.monotonic() < deadline, proc.communicate()
        time.sleep(0.02)
    proc.send_signal(sig)
    _, err = proc.communicate(timeout=60)
    assert proc.returncode == status, err
    lines = err.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith(word) and "chunks saved" in lines[0] and "Traceback" not in err
    assert not list((out / ".parts").glob("*.lock"))
    rerun = _cli("run", "fanout-probe", "--out", str(out), "--no-progress", "--workers", "1", "--set", "delay=0.3")
    assert rerun.returncode == 0 and "chunks resumed" in rerun.stdout, rerun.stderr


def test_plot_of_a_file_missing_a_variable(quick_results, tmp_path, capsys):
    with xr.open_dataset(quick_results / "fig8.nc") as ds:
        ds.load().drop_vars("region").to_netcdf(tmp_path / "fig8.nc")
    assert main(["plot", str(tmp_path / "fig8.nc")]) == 2
    _one_line_error(capsys.readouterr().err, "lacks the variable(s) region")


def test_info_of_a_file_with_label_coordinates(tmp_path, capsys):
    names = [v.name for v in registry.get("work-precision").variables]  # a file of the study has them all
    ds = xr.Dataset({name: (("integrator",), [1e-4, 2e-4], {"units": "s"}) for name in names},
                    coords={"integrator": ("integrator", ["rimroll_dop853", "scipy_RK45"], {"units": "1"})},
                    attrs={"study": "work-precision", "rimroll_version": "0"})
    ds.to_netcdf(tmp_path / "wp.nc")
    assert main(["info", str(tmp_path / "wp.nc")]) == 0
    assert "rimroll_dop853, scipy_RK45 (2 points)" in capsys.readouterr().out


def test_info_into_a_closed_pipe(quick_results):
    cmd = f"{sys.executable} -m rimroll.study info {quick_results / 'fig8.nc'} | head -c 10 >/dev/null"
    run = subprocess.run(["bash", "-o", "pipefail", "-c", cmd], capture_output=True, text=True, timeout=120)
    assert "Traceback" not in run.stderr and "BrokenPipe" not in run.stderr and run.returncode == 0, run.stderr


# ================================================================ 12. lanes not ok are counted
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
    assert _run(tmp_path, *sets, name="outcome-cube") == 0
    err = capsys.readouterr().err
    with xr.open_dataset(tmp_path / "outcome-cube.nc") as ds:
        bad, total = int((ds.status != 0).sum()), ds.status.size
    assert bad == (total + 1) // 2 and f"warning: {bad} of {total} lanes" in err and "see the variable 'status'" in err


# ================================================================ 13. parts of other inputs are kept
def _other_inputs_parts(tmp_path):
    """Parts folders as an interrupted run of other inputs (this study) and a run of another study leave them."""
    stale = tmp_path / ".parts" / "fanout-probe-0123456789abcdef"
    stale.mkdir(parents=True)
    for k in range(3):
        (stale / f"chunk-{k}.npz").write_bytes(b"x" * 1000)
    other_study = tmp_path / ".parts" / "fig8-0123456789abcdef"
    other_study.mkdir()
    return stale, other_study


def test_a_computing_run_keeps_and_names_the_parts_of_an_interrupted_run_of_other_inputs(probe, tmp_path, capsys):
    """What a user finished computing is not lost: the interrupted run resumes from its parts."""
    stale, other_study = _other_inputs_parts(tmp_path)
    assert _run(tmp_path) == 0
    assert len(list(stale.glob("chunk-*.npz"))) == 3 and other_study.exists()
    assert sorted(p.name for p in (tmp_path / ".parts").iterdir()) == sorted([other_study.name, stale.name])
    err = capsys.readouterr().err
    assert f"{stale} holds 3 chunks saved by an interrupted run of fanout-probe with other settings: kept" in err


def test_a_run_that_reuses_its_file_keeps_the_parts_of_other_inputs(probe, tmp_path, capsys):
    assert _run(tmp_path) == 0
    stale, _ = _other_inputs_parts(tmp_path)
    capsys.readouterr()
    assert _run(tmp_path) == 0
    out, err = capsys.readouterr()
    assert "exists, not recomputing" in out and f"{stale} holds 3 chunks" in err
    assert len(list(stale.glob("chunk-*.npz"))) == 3


def test_an_interrupted_run_whose_file_another_run_wrote_is_told_that_force_resumes_it(probe, tmp_path, capsys):
    """A interrupted (its chunks saved), B of other settings writes NAME.nc, A again: refused as another
    run's file, and the line says A's chunks wait and --force resumes them; --force does."""
    plan = make_plan(probe, sets=["v_throw=7"])
    store = PartStore(tmp_path, "fanout-probe", plan.fingerprint)  # as A's interrupted run left them
    arrays = {"f": np.zeros((1, 1, 4, 3)), "code": np.zeros((1, 1, 4, 3), dtype=np.int8)}
    store.save(0, arrays)
    assert _run(tmp_path) == 0  # B: other settings; A's parts are kept
    capsys.readouterr()
    assert _run(tmp_path, "--set", "v_throw=7") == 2
    _one_line_error(capsys.readouterr().err, "holds another run", "1 chunk of this very run, interrupted, wait in",
                    "--force resumes them")
    assert _run(tmp_path, "--set", "v_throw=7", "--force") == 0
    with xr.open_dataset(tmp_path / "fanout-probe.nc") as ds:
        assert ds.attrs["run_fingerprint"] == plan.fingerprint


def test_parts_left_by_a_kill_during_cleanup_are_removed(probe, tmp_path, capsys):
    assert _run(tmp_path) == 0
    plan = make_plan(probe)
    left = PartStore(tmp_path, "fanout-probe", plan.fingerprint)  # as if killed inside store.remove()
    left.save(0, {"f": np.zeros((1, 1, 4, 3)), "code": np.zeros((1, 1, 4, 3), dtype=np.int8)})
    assert _run(tmp_path) == 0 and "exists, not recomputing" in capsys.readouterr().out
    assert not (tmp_path / ".parts").exists()


def test_the_time_left_leaves_out_the_chunks_that_waited_for_the_compile():
    """A first run's first chunk on each thread includes the kernels' compile: 32 s per chunk there
    and 2 s after said 'about 4 min left' for a run that took 35 s (found by a new user)."""
    from rimroll.study import runguard

    assert runguard.seconds_per_chunk([32.0, 31.0], 2, 16) is None  # one round: wait for the next
    assert runguard.seconds_per_chunk([32.0, 31.0, 2.0], 2, 16) is None
    assert runguard.seconds_per_chunk([32.0, 31.0, 2.0, 2.5], 2, 16) == 2.25
    assert runguard.seconds_per_chunk([3.0], 2, 1) == 3.0  # fewer chunks than two rounds: what there is


def test_estimate_line_only_for_long_runs(probe):
    import io as _io

    from rimroll.study import runguard

    plan = make_plan(probe)
    quiet, loud = _io.StringIO(), _io.StringIO()
    runguard.estimate(plan, 0.5, 100, 2, stream=quiet)  # 25 s: nothing to say
    runguard.estimate(plan, 2.0, 5400, 2, stream=loud)  # 5400 s of work left
    assert quiet.getvalue() == ""
    assert loud.getvalue() == "study: fanout-probe: about 1.5 h left for 5400 chunks (2 s per chunk on 2 threads)\n"


def test_a_python_warning_during_a_command_is_one_line(tmp_path):
    """numpy's overflow at an extreme (valid) setting printed Python's two lines, the second the source;
    the command prints one, naming the warning and where it came from, and its exit status stands."""
    run = _cli("run", "fig8", "--quick", "--set", "j=1e-300", "--out", str(tmp_path), "--no-progress")
    assert run.returncode == 0, run.stderr
    lines = run.stderr.strip().splitlines()
    assert lines and all(line.startswith("study: ") for line in lines), run.stderr
    assert any(line.startswith("study: warning: RuntimeWarning: overflow") for line in lines)


def test_ctrl_c_while_the_figure_is_drawn_says_the_result_is_complete(probe, tmp_path, capsys, monkeypatch):
    """The .nc is written when the figure is drawn: a Ctrl-C there said only 'interrupted'."""
    from rimroll.study import cli

    def drawing(*args, **kwargs):
        raise KeyboardInterrupt

    monkeypatch.setattr(cli, "_draw", drawing)
    assert _run(tmp_path) == 130
    err = capsys.readouterr().err.strip()
    assert err.startswith("study: interrupted while drawing the figure;") and "\n" not in err
    assert f"{tmp_path / 'fanout-probe.nc'} is complete" in err and (tmp_path / "fanout-probe.nc").is_file()
