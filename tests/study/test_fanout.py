"""Fan-out of studies into cubes: --set sweeps, parts on disk, resume after SIGKILL, fingerprints,
the run lock, a real dask.distributed cluster, lazy reading.

The slow, killable study is ``tests/helpers/fanout_probe.py`` (loaded through ``RIMROLL_STUDY_MODULES``).
"""

from __future__ import annotations

import fcntl
import os
import signal
import subprocess
import sys
import time
import warnings

import numpy as np
import pytest
import xarray as xr

from rimroll.study import registry
from rimroll.study.cli import main
from rimroll.study.parts import PartStore
from rimroll.study.plan import make_plan
from rimroll.study.registry import PLUGIN_ENV
from tests.helpers.paths import HELPERS

PROBE = str(HELPERS / "fanout_probe.py")
N_PROBE = 3 * 2 * 2  # mu x v_throw x (8 x points in chunks of 4)


@pytest.fixture
def probe(monkeypatch):
    monkeypatch.setenv(PLUGIN_ENV, PROBE)
    monkeypatch.delenv("FANOUT_PROBE_FAIL_MU", raising=False)
    return registry.get("fanout-probe")


def _env():
    return {**os.environ, PLUGIN_ENV: PROBE}


def _run(out, *extra, name="fanout-probe"):
    return main(["run", name, "--out", str(out), "--no-progress", *extra])


def _log_lines(path) -> list[str]:
    return path.read_text().splitlines() if path.exists() else []


def _assert_same_data(a, b):
    """Same coordinates, data variables and variable attributes (global provenance may differ, and so
    may the scalar coordinates of settings that do not change the numbers, such as the probe's delay)."""
    with xr.open_dataset(a) as x, xr.open_dataset(b) as y:
        assert list(x.dims) == list(y.dims) and set(x.data_vars) == set(y.data_vars)
        for name in [*(c for c in x.coords if x[c].ndim), *x.data_vars]:
            assert x[name].dtype == y[name].dtype, name
            np.testing.assert_array_equal(x[name].values, y[name].values, err_msg=name)
            assert x[name].attrs.keys() == y[name].attrs.keys(), name


def _chunk_ids(plan, ks):
    """The (mu, v_throw, x0) that the probe logs for chunks ``ks`` of ``plan``."""
    out = set()
    for k in ks:
        r = plan.region(k)
        out.add((float(plan.outer[0].values[r[0].start]), float(plan.outer[1].values[r[1].start]),
                 float(plan.grid[0].values[r[2].start])))
    return out


def _parse_ids(lines):
    return {tuple(float(w) for w in line.split()) for line in lines}


# ---------------------------------------------------------------- --set parsing
def test_set_forms_make_axes(probe):
    plan = make_plan(probe, False, {"mu": [0.25, 1, 4], "v_throw": 3, "j": np.linspace(0.4, 0.6, 5), "n_x": 6})
    assert [a.name for a in plan.outer] == ["mu", "j"]  # scalar v_throw is a setting again
    np.testing.assert_allclose(plan.outer[0].values, [0.25, 1.0, 4.0])
    np.testing.assert_allclose(plan.outer[1].values, [0.4, 0.45, 0.5, 0.55, 0.6])  # inclusive
    assert plan.settings["v_throw"] == 3.0 and plan.grid[0].values.size == 6
    assert plan.shape == (3, 5, 6, 3) and plan.nc_chunks == (1, 1, 4, 3)
    assert plan.n_chunks == 3 * 5 * 2  # outer axes chunked by 1, x by 4
    s, p = plan.settings_at(plan.n_chunks - 1)
    assert (p.mu, p.j, s["mu"], s["j"]) == (4.0, 0.6, 4.0, 0.6)
    # rho_over_R keeps R and a and moves r; a grid axis takes new values
    plan = make_plan(probe, False, {"rho_over_R": [0.5, 0.6], "x": np.linspace(0, 2, 3)})
    _, p = plan.settings_at(plan.n_chunks - 1)
    assert p.R == 0.225 and p.a == 0.01 and p.rho == pytest.approx(0.6 * 0.225)
    np.testing.assert_allclose(plan.grid[0].values, [0.0, 1.0, 2.0])


@pytest.mark.parametrize("item, expect", [
    ("nosuch=1,2", "unknown setting 'nosuch'"),
    ("n_x=4,8", "cannot be swept"),
    ("mu=0.5:2:0", "num >= 2"),
    ("mu=0.5:2", "start:stop:num"),
    ("mu=0.5:2:x", "must be an integer"),
    ("mu=0.5,,2", "empty item"),
    ("mu=-1,1", "parameter mu=-1.0 is out of range"),
    ("j=0,0.5", "parameter j=0.0 is out of range"),
    ("rho_over_R=0.5,1.5", "rho_over_R=1.5"),
    ("v_throw=-2:3:4", "v_throw=-2.0 is out of range"),
    ("mu=2,1,2", "strictly monotonic"),
    ("mu=-1e308:1e308:3", "the range's points are not finite numbers"),
    ("v_throw=\uff11", "expected a number"),  # a full-width digit: float() reads it as 1
    ("v_throw=1_0", "expected a number"),  # a digit group: float() reads it as 10
    ("mu=1_0,2", "expected a number"),
    ("mu=0.5:2:1_0", "must be an integer"),
])
def test_bad_set_is_one_line_exit_2(probe, tmp_path, capsys, item, expect):
    assert _run(tmp_path, "--set", item) == 2
    err = capsys.readouterr().err
    assert err.startswith("study: error:") and len(err.strip().splitlines()) == 1 and expect in err, err
    assert not list(tmp_path.iterdir())


def test_a_setting_given_twice_is_refused_not_silently_the_last(probe, tmp_path, capsys):
    assert _run(tmp_path, "--set", "mu=1", "--set", "mu=2") == 2
    err = capsys.readouterr().err
    assert len(err.strip().splitlines()) == 1 and "--set mu is given 2 times" in err, err


@pytest.mark.parametrize("argv, needle", [
    (["--set", "backend=cpu", "--backend", "cpu"], "--set backend is given 2 times (--backend is --set backend=...)"),
    (["--set", "adaptive=true,false"], "adaptive takes true or false, not a list or range"),
    (["--set", "n_beta=24", "--set", "beta=0.8:1.8:10"], "either as values or as a number of points, not both"),
])
def test_settings_that_cannot_mean_what_they_say_are_one_line(tmp_path, capsys, argv, needle):
    from rimroll.study.cli import main

    with warnings.catch_warnings():
        warnings.simplefilter("error")
        assert main(["run", "fig11", "--quick", "--out", str(tmp_path), *argv]) == 2
    err = capsys.readouterr().err
    assert len(err.strip().splitlines()) == 1 and needle in err, err
    assert "a list sweeps it" not in err  # none of these can be swept in fig11
    assert not list(tmp_path.iterdir())


def test_an_axis_of_two_infinities_is_one_line_without_a_numpy_warning(tmp_path, capsys):
    from rimroll.study.cli import main

    with warnings.catch_warnings():
        warnings.simplefilter("error")  # a RuntimeWarning of inf - inf would raise here
        assert main(["run", "outcome-cube", "--quick", "--set", "mu=inf,inf", "--out", str(tmp_path)]) == 2
    err = capsys.readouterr().err
    assert len(err.strip().splitlines()) == 1 and "strictly monotonic" in err, err


def test_bad_set_in_a_subprocess(tmp_path):
    run = subprocess.run([sys.executable, "-m", "rimroll.study", "run", "realisable-cube", "--quick", "--out",
                          str(tmp_path), "--set", "rho_over_R=0.5:1.5:3"], capture_output=True, text=True,
                         timeout=120)
    assert run.returncode == 2 and run.stderr.startswith("study: error:"), run.stderr
    assert len(run.stderr.strip().splitlines()) == 1 and "rho_over_R" in run.stderr


# ---------------------------------------------------------------- resume after SIGKILL
def test_sigkill_then_resume_recomputes_nothing_finished(probe, tmp_path):
    log = tmp_path / "computed.log"
    out = tmp_path / "out"
    cmd = [sys.executable, "-m", "rimroll.study", "run", "fanout-probe", "--out", str(out), "--workers", "1",
           "--no-progress", "--set", "delay=0.35", "--set", f"log={log}"]
    proc = subprocess.Popen(cmd, env=_env(), stdout=subprocess.PIPE, stderr=subprocess.PIPE)
    plan = make_plan(probe, False, {"delay": 0.35, "log": str(log)})
    parts = PartStore(out, "fanout-probe", plan.fingerprint)
    deadline = time.monotonic() + 60
    while len(list(parts.dir.glob("chunk-*.npz"))) < 3:
        assert proc.poll() is None, proc.communicate()
        assert time.monotonic() < deadline, "the run never wrote 3 parts"
        time.sleep(0.02)
    proc.send_signal(signal.SIGKILL)
    proc.wait(timeout=30)
    finished = {int(p.stem.split("-")[1]) for p in parts.dir.glob("chunk-*.npz")}
    assert 3 <= len(finished) < N_PROBE and not (out / "fanout-probe.nc").exists()
    before = len(_log_lines(log))

    rerun = subprocess.run(cmd, env=_env(), capture_output=True, text=True, timeout=120)
    assert rerun.returncode == 0, rerun.stderr
    assert f"{len(finished)} of {N_PROBE} chunks resumed" in rerun.stdout
    recomputed = _parse_ids(_log_lines(log)[before:])
    assert len(_log_lines(log)) - before == N_PROBE - len(finished)  # each missing chunk once
    assert recomputed == _chunk_ids(plan, set(range(N_PROBE)) - finished)  # and no finished one
    assert not (out / ".parts").exists()

    clean = tmp_path / "clean"
    assert _run(clean) == 0  # uninterrupted, in this process
    _assert_same_data(out / "fanout-probe.nc", clean / "fanout-probe.nc")


# ---------------------------------------------------------------- fingerprint, corrupt parts, lock
def test_fingerprint_and_corrupt_parts(probe, tmp_path, monkeypatch):
    log = tmp_path / "computed.log"
    out = tmp_path / "out"
    sets = ["--set", f"log={log}", "--workers", "1"]
    monkeypatch.setenv("FANOUT_PROBE_FAIL_MU", "2.0")
    with pytest.raises(RuntimeError, match="probe asked to fail"):
        _run(out, *sets)
    monkeypatch.delenv("FANOUT_PROBE_FAIL_MU")
    plan = make_plan(probe, False, {"log": str(log)})
    store = PartStore(out, "fanout-probe", plan.fingerprint)
    kept = sorted(int(p.stem.split("-")[1]) for p in store.dir.glob("chunk-*.npz"))
    assert 2 <= len(kept) < N_PROBE and not (out / "fanout-probe.nc").exists()

    # one changed value: a new fingerprint, a new parts folder, every chunk computed afresh
    changed = make_plan(probe, False, {"log": str(log), "v_throw": [1, 2.5]})
    assert changed.fingerprint != plan.fingerprint
    other = tmp_path / "other"
    n0 = len(_log_lines(log))
    assert _run(other, *sets, "--set", "v_throw=1,2.5") == 0
    assert len(_log_lines(log)) - n0 == N_PROBE
    assert store.dir.is_dir() and sorted(int(p.stem.split("-")[1]) for p in store.dir.glob("chunk-*.npz")) == kept
    assert make_plan(probe, False, {"log": str(log), "k_r": 0.001}).fingerprint != plan.fingerprint

    # damage two kept parts: truncated, and a valid zip with a wrong checksum
    truncated, tampered = store.path(kept[0]), store.path(kept[1])
    truncated.write_bytes(truncated.read_bytes()[:100])
    good = store.load(kept[1], plan.expected(kept[1]))
    good["f"] = good["f"] + 1.0
    np.savez(tampered, **good, __sha256__=np.array("0" * 64))
    assert store.load(kept[1], plan.expected(kept[1])) is None
    n0 = len(_log_lines(log))
    assert _run(out, *sets) == 0
    assert len(_log_lines(log)) - n0 == N_PROBE - len(kept) + 2
    assert _parse_ids(_log_lines(log)[n0:]) >= _chunk_ids(plan, kept[:2])
    assert _run(tmp_path / "clean", "--set", f"log={tmp_path / 'other.log'}") == 0
    _assert_same_data(out / "fanout-probe.nc", tmp_path / "clean" / "fanout-probe.nc")


def test_second_run_refuses_while_locked(probe, tmp_path, capsys):
    plan = make_plan(probe)
    store = PartStore(tmp_path, "fanout-probe", plan.fingerprint)
    store.root.mkdir(parents=True)
    with open(store.lock_path, "w") as held:
        fcntl.flock(held, fcntl.LOCK_EX | fcntl.LOCK_NB)
        assert _run(tmp_path) == 2
    err = capsys.readouterr().err
    assert err.startswith("study: error:") and "in progress" in err and len(err.strip().splitlines()) == 1
    assert not (tmp_path / "fanout-probe.nc").exists()
    assert _run(tmp_path) == 0  # lock released: runs


def test_unreachable_scheduler_is_a_user_error(probe, tmp_path, capsys):
    import dask

    with dask.config.set({"distributed.comm.timeouts.connect": "1s"}):
        assert _run(tmp_path, "--scheduler", "tcp://127.0.0.1:9", "--timeout", "2") == 2  # dask retries until then
    assert "cannot connect to the dask scheduler" in capsys.readouterr().err


# ---------------------------------------------------------------- distributed, lazy reading
def test_distributed_cluster_gives_identical_file(tmp_path):
    from distributed import LocalCluster

    quick = ["--quick", "--set", "v_throw=4,8", "--set", "j=0.5,0.6"]
    with LocalCluster(n_workers=2, threads_per_worker=1, processes=True, dashboard_address=None) as cluster:
        assert _run(tmp_path / "dist", *quick, "--scheduler", cluster.scheduler_address,
                    name="realisable-cube") == 0
    assert _run(tmp_path / "local", *quick, "--workers", "2", name="realisable-cube") == 0
    _assert_same_data(tmp_path / "dist" / "realisable-cube.nc", tmp_path / "local" / "realisable-cube.nc")


def test_cube_opens_lazily_chunked_along_swept_axes(tmp_path):
    assert _run(tmp_path, "--quick", name="realisable-cube") == 0
    with xr.open_dataset(tmp_path / "realisable-cube.nc", chunks={}) as ds:
        assert list(ds.region.dims) == ["mu", "v_throw", "j", "rho_over_R", "beta0", "omega30"]
        # stored in chunks of about a million values, so several outer points a chunk (computed one by one)
        assert ds.region.data.chunksize == (2, 3, 2, 2, 121, 80)
        one = ds.region.sel(mu=1.0, v_throw=10.0, j=2 / 3, rho_over_R=ds.rho_over_R[-1])
        assert one.data.npartitions == 1
        area = float(ds.area_A.sel(mu=1.0, v_throw=10.0, j=2 / 3, rho_over_R=ds.rho_over_R[-1]))
        cell = (2 * np.pi / 121) * (140.0 / 79)
        assert area == pytest.approx(float((one == 1).sum()) * cell)
        assert ds.area_A.attrs["units"] == "rad s-1"
        assert (tmp_path / "realisable-cube.png").stat().st_size > 0


def test_outcome_cube_matches_direct_simulate(tmp_path):
    from rimroll import solver
    sets = ["--quick", "--set", "mu=1", "--set", "k_r=0,0.02", "--set", "k_d=0", "--set", "omega2=105",
            "--set", "n_beta=4", "--set", "n_omega1=5"]
    assert _run(tmp_path, *sets, name="outcome-cube") == 0
    with xr.open_dataset(tmp_path / "outcome-cube.nc") as ds:
        assert list(ds.outcome.dims) == ["k_r", "beta", "omega1"]
        assert ds.outcome.attrs["flag_meanings"].split()[:2] == ["fall_in", "fall_out"]
        b, w = np.meshgrid(ds.beta.values, ds.omega1.values, indexing="ij")
        states = np.stack([b, w, np.full_like(b, 105.0), np.full_like(b, 10.0)], axis=-1)
        ref = solver.simulate(states, solver.Params(mu=1.0, k_r=0.02), t_max=20.0, rtol=1e-6, atol=1e-9, workers=1)
        np.testing.assert_array_equal(ds.outcome.sel(k_r=0.02).values, ref["outcome"])
        np.testing.assert_array_equal(ds.t_end.sel(k_r=0.02).values, ref["t_end"])


def test_the_event_loops_logs_are_silenced_while_a_stopped_local_cluster_is_torn_down(monkeypatch):
    """Ctrl-C during a run: the teardown of the local cluster may log 'Exception in callback' with a
    traceback through tornado (seen once in 35 interrupted runs); those loggers are off while the
    cluster closes after an exception, and back as they were afterwards."""
    import logging

    import distributed

    from rimroll.study import fanout

    seen = []
    close = distributed.Client.__exit__

    def exit_and_look(self, *exc):
        seen.append(logging.getLogger("tornado.application").isEnabledFor(logging.CRITICAL))
        return close(self, *exc)

    monkeypatch.setattr(distributed.Client, "__exit__", exit_and_look)
    before = logging.getLogger("tornado.application").level
    with pytest.raises(KeyboardInterrupt):
        with fanout.client(workers=1):
            raise KeyboardInterrupt
    with fanout.client(workers=1):
        pass
    assert seen == [False, True]  # silenced only when stopped
    assert logging.getLogger("tornado.application").level == before


def test_an_empty_out_folder_is_refused(probe, tmp_path, capsys, monkeypatch):
    """--out "" wrote into the current directory."""
    monkeypatch.chdir(tmp_path)
    assert main(["run", "fanout-probe", "--out", "", "--no-progress"]) == 2
    err = capsys.readouterr().err
    assert err.startswith("study: error: argument --out: an empty folder name") and len(err.splitlines()) == 1
    assert not list(tmp_path.iterdir())
