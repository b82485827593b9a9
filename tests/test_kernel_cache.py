"""The disk cache of compiled kernels: per user, per digest of all solver sources, never inside
the package, and without touching numba's own cache location for other code."""

import os
import pathlib

import numba
import pytest

from rimroll import solver
from rimroll.solver import _jit
from rimroll.solver.engine import kernels
from rimroll.solver.physics import rolling


def test_solver_kernels_cache_in_the_per_user_directory_of_the_sources_digest():
    package = pathlib.Path(solver.__file__).resolve().parent
    for func in (rolling.rolling_rhs, kernels.scene_rolling):
        path = pathlib.Path(func._cache._cache_path).resolve()
        assert path.is_relative_to(_jit.cache_dir().resolve())
        assert not path.is_relative_to(package)
    assert _jit.cache_dir().name == f"numba-{_jit.SOURCES_DIGEST[:16]}"


def test_other_numba_code_keeps_its_own_cache_location():
    assert numba.config.CACHE_DIR == os.environ.get("NUMBA_CACHE_DIR", "")

    @numba.njit(cache=True)
    def outside(x):
        return x + 1

    assert not pathlib.Path(outside._cache._cache_path).resolve().is_relative_to(_jit.cache_dir().resolve())


def test_cache_dir_follows_the_environment(monkeypatch, tmp_path):
    monkeypatch.setenv("RIMROLL_CACHE_DIR", str(tmp_path))
    assert _jit.cache_dir() == tmp_path / f"numba-{_jit.SOURCES_DIGEST[:16]}"
    monkeypatch.delenv("RIMROLL_CACHE_DIR")
    monkeypatch.setenv("XDG_CACHE_HOME", str(tmp_path / "xdg"))
    assert _jit.cache_dir() == tmp_path / "xdg" / "rimroll" / f"numba-{_jit.SOURCES_DIGEST[:16]}"


def test_digest_changes_when_any_solver_source_changes(tmp_path, monkeypatch):
    (tmp_path / "events.py").write_text("x = 1\n")
    (tmp_path / "kernels.py").write_text("y = 1\n")
    monkeypatch.setattr(_jit, "_SOURCES", tmp_path)
    before = _jit.sources_digest()
    assert _jit.sources_digest() == before
    (tmp_path / "events.py").write_text("x = 2\n")  # a callee edited: every kernel's cache moves
    assert _jit.sources_digest() != before
    (tmp_path / "physics").mkdir()  # and a module of a room
    (tmp_path / "physics" / "rolling.py").write_text("z = 1\n")
    before = _jit.sources_digest()
    (tmp_path / "physics" / "rolling.py").write_text("z = 2\n")
    assert _jit.sources_digest() != before


def test_result_fingerprints_cover_every_room_of_the_solver(monkeypatch):
    """A run's code digest (its parts and results are never reused across it) changes with any
    source of the solver's rooms, not only with solver/*.py."""
    from rimroll.study import plan, registry

    study = registry.get("fig8")
    before = plan.code_digest(study)
    monkeypatch.setattr(_jit, "SOURCES_DIGEST", _jit.SOURCES_DIGEST[::-1])  # as if physics/rolling.py changed
    assert plan.code_digest(study) != before


def test_a_first_compile_is_announced_once(monkeypatch, caplog):
    """A notice at INFO under the logger 'rimroll' (tests/test_api.py: on stderr until the application
    configures logging, silenced by logging.getLogger('rimroll').setLevel(logging.WARNING))."""
    import importlib
    import logging

    simulate_module = importlib.import_module("rimroll.solver.engine.simulate")  # the module, not the function

    monkeypatch.setattr(simulate_module, "kernels_cached", lambda scene=None: False)
    monkeypatch.setattr(simulate_module, "_announced", set())
    x = [[1.1, 2.0, 35.0, 10.0]]

    def notices():
        found = [r for r in caplog.records if "first run only" in r.getMessage()]
        assert all(r.levelno == logging.INFO and r.name.startswith("rimroll.solver") for r in found)
        caplog.clear()
        return [r.getMessage() for r in found]

    solver.simulate(x, solver.Params(mu=float("inf")), t_max=0.1)
    solver.simulate(x, solver.Params(mu=float("inf")), t_max=0.1)
    said = notices()
    assert len(said) == 1 and "rolling scene" in said[0] and str(_jit.cache_dir()) in said[0]
    solver.simulate(x, solver.Params(mu=1.0), t_max=0.1)  # another scene: its own line
    said = notices()
    assert len(said) == 1 and "hybrid scene" in said[0]


def test_the_cache_index_of_the_scene_kernel_is_found_after_a_run():
    solver.simulate([[1.1, 2.0, 35.0, 10.0]], solver.Params(mu=float("inf")), t_max=0.1)
    assert any(_jit.cache_dir().glob("**/kernels.scene_rolling-*.nbi"))


def test_functions_taking_compiled_functions_are_not_cached_on_their_own():
    """Their cache key would name one process's function object (see solver._compile.kernel)."""
    from rimroll.solver.engine import events, stepper

    for func in (kernels.run_phase, events.next_event, events.locate, events.minimum, events.value_at,
                 stepper.initial_step, stepper.dense_prepare, stepper.rk_step, stepper.attempt):
        assert type(func._cache).__name__ == "NullCache", func


_CHILD = ("import sys, time; from rimroll import solver; from rimroll.solver.engine import kernels\n"
          "t = time.perf_counter()\n"
          "solver.simulate([[1.1, 2.0, 35.0, 10.0]], solver.Params(mu=float(sys.argv[1]), k_r=float(sys.argv[2])),"
          " t_max=0.1, workers=1)\n"
          "print([bool(k.signatures) for k in kernels.SCENE_KERNELS.values()], time.perf_counter() - t)\n")


def _child(tmp_path, mu, k_r, cache):
    import subprocess
    import sys

    env = dict(os.environ)  # the installed rimroll
    if cache is not None:
        env["RIMROLL_CACHE_DIR"] = str(cache)
    out = subprocess.run([sys.executable, "-c", _CHILD, str(mu), str(k_r)], capture_output=True, text=True,
                         cwd=tmp_path, env=env)
    assert out.returncode == 0, out.stderr[-2000:]
    flags, seconds = out.stdout.strip().rsplit("] ", 1)
    return flags + "]", float(seconds), out.stderr


@pytest.mark.slow
def test_scenes_compiled_in_separate_processes_share_one_cache(tmp_path):
    """Cold cache: a process compiles only the scene it runs; a later process compiles another
    scene into the same cache without error, and a third loads both without compiling."""
    cache = tmp_path / "cache"
    flags, first, err = _child(tmp_path, "inf", 0.0, cache)
    assert flags == "[True, False]" and "rolling scene" in err
    flags, _, err = _child(tmp_path, 1.0, 0.0, cache)
    assert flags == "[False, True]" and "hybrid scene" in err
    for mu in ("inf", 1.0):
        _, again, err = _child(tmp_path, mu, 0.0, cache)
        assert "first run only" not in err
        assert again < first / 5  # loaded from the cache, not compiled


def test_a_rolling_only_process_builds_only_the_rolling_only_kernel(tmp_path):
    """A process compiles (or loads) a scene's kernel when it first runs that scene, and no other."""
    flags, _, _ = _child(tmp_path, "inf", 0.0, None)
    assert flags == "[True, False]"


@pytest.mark.slow
def test_the_step_loop_is_compiled_twice_for_the_four_scenes(tmp_path):
    """run_phase is the costly part of the first compile: once for the scenes that only roll (no
    friction cone, no slipping code) and once for those that slip (one step loop for both phases);
    whether a scene is conservative is a run-time setting, never a compile. A cold cache, so that
    the process compiles everything it runs."""
    import subprocess
    import sys

    code = ("from rimroll import solver; from rimroll.solver.engine import kernels\n"
            "for mu, k_r in ((float('inf'), 0.0), (float('inf'), 0.02), (1.0, 0.0), (1.0, 0.02)):\n"
            "    solver.simulate([[1.1, 2.0, 35.0, 10.0]], solver.Params(mu=mu, k_r=k_r), t_max=0.1, workers=1)\n"
            "for s in kernels.run_phase.signatures:\n"
            "    print(str(s[0]).split('function ')[1].split(' ')[0])\n"
            "print([bool(k.signatures) for k in kernels.SCENE_KERNELS.values()])\n")
    env = {**os.environ, "RIMROLL_CACHE_DIR": str(tmp_path / "cache")}
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, cwd=tmp_path, env=env)
    assert out.returncode == 0, out.stderr[-2000:]
    lines = out.stdout.split("\n")[:-1]
    assert sorted(lines[:-1]) == ["hybrid_rhs", "rolling_rhs"] and lines[-1] == "[True, True]"


def test_threads_decorating_at_once_all_see_the_kernel_cache_location(monkeypatch):
    """numba reads its global CACHE_DIR setting while a function is decorated; two threads in
    njit_cached at once must not restore it under each other (one thread's function would get its cache
    in a folder of the current directory). A stand-in for numba.njit records the setting in each
    thread: the first waits (at most 0.3 s) for the second to enter, the second records again once
    the first has left njit_cached, where an unguarded restore would have reset the setting."""
    import threading

    seen = []
    second_inside = threading.Event()
    first_done = threading.Event()
    calls = []

    def njit(**options):
        def decorate(func):
            calls.append(func)
            seen.append(numba.config.CACHE_DIR)
            if len(calls) == 1:
                second_inside.wait(0.3)
            else:
                second_inside.set()
                first_done.wait(0.3)
            seen.append(numba.config.CACHE_DIR)
            return func
        return decorate

    monkeypatch.setattr(numba, "njit", njit)

    def first():
        _jit.njit_cached(lambda x: x)
        first_done.set()

    threads = [threading.Thread(target=first), threading.Thread(target=lambda: _jit.njit_cached(lambda x: x))]
    threads[0].start()
    while not calls:
        threading.Event().wait(0.001)
    threads[1].start()
    for t in threads:
        t.join()
    assert seen == [str(_jit.cache_dir())] * 4
    assert numba.config.CACHE_DIR == os.environ.get("NUMBA_CACHE_DIR", "")
