"""The disk cache of compiled kernels: per user, per digest of all solver sources, never inside
the package, and without touching numba's own cache location for other code."""

import importlib
import os
import pathlib
import time

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


def test_a_compile_is_announced_with_the_time_measured_on_this_machine(monkeypatch, caplog, tmp_path):
    """A notice at INFO under the logger 'rimroll' (tests/study/test_api.py: on stderr until the application
    configures logging, silenced by logging.getLogger('rimroll').setLevel(logging.WARNING)) for each kernel
    and signature numba must compile (here: a stand-in for the check and the child process), with no estimate
    until a compile of that kernel was measured on this machine, then that time."""
    import logging

    from rimroll.solver.engine import compiling

    monkeypatch.setenv("RIMROLL_CACHE_DIR", str(tmp_path))  # where the measured times are kept
    compiled = set()
    monkeypatch.setattr(compiling, "is_compiled", lambda dispatcher, types: (dispatcher, types) in compiled)

    def child(scene, types, name, t0):
        time.sleep(0.3)  # a compile that takes time to measure
        compiled.add((compiling.scene_code.kernel_of(scene), types))
        return True

    monkeypatch.setattr(compiling, "_compile_in_child", child)
    x = [[1.1, 2.0, 35.0, 10.0]]

    def notices():
        found = [r for r in caplog.records if "first run of this install only" in r.getMessage()]
        assert all(r.levelno == logging.INFO and r.name.startswith("rimroll.solver") for r in found)
        caplog.clear()
        return [r.getMessage() for r in found]

    caplog.set_level(logging.INFO, "rimroll")
    solver.simulate(x, solver.Params(mu=float("inf")), t_max=0.1, method="dp5")  # the kernel, not the exact solver
    solver.simulate(x, solver.Params(mu=float("inf")), t_max=0.1, method="dp5")
    said = notices()
    assert len(said) == 1 and "rolling scene (dp5)" in said[0] and str(_jit.cache_dir()) in said[0]
    assert "no earlier compile on this machine" in said[0]
    solver.simulate(x, solver.Params(mu=float("inf")), t_max=0.1, method="dop853")  # another signature
    said = notices()
    assert len(said) == 1 and "rolling scene (dop853)" in said[0]
    solver.simulate(x, solver.Params(mu=1.0), t_max=0.1)  # another scene: its own line
    said = notices()
    assert len(said) == 1 and "hybrid scene (dp5)" in said[0]
    compiled.clear()  # as in another install: compiled again, now with the time the last compile took
    solver.simulate(x, solver.Params(mu=float("inf")), t_max=0.1, method="dp5")
    said = notices()
    assert len(said) == 1 and "as its last compile on this machine" in said[0]
    assert (tmp_path / compiling.TIMES_FILE).is_file()


_PROBE = ("import sys; from rimroll import solver; from rimroll.solver.engine import compiling, scene_code\n"
          "def probe(scene, method, args):\n"
          "    d = scene_code.kernel_of(scene)\n"
          "    print(compiling.is_compiled(d, compiling.argument_types(d, args)), compiling.__file__)\n"
          "    sys.exit(0)\n"
          "compiling.ensure_compiled = probe\n"
          "solver.simulate([[1.1, 2.0, 35.0, 10.0]], solver.Params(mu=float('inf')), t_max=0.1, workers=1,"
          " method='dp5')\n")


def _second_install(tmp_path) -> pathlib.Path:
    """A copy of the installed package (its sources, as another virtual environment holds them) at another
    path: the same sources digest, hence the same cache folder, but numba's index files of another path."""
    import shutil

    import rimroll

    site = tmp_path / "site"
    shutil.copytree(pathlib.Path(rimroll.__file__).resolve().parent, site / "rimroll",
                    ignore=shutil.ignore_patterns("__pycache__"))
    for room in ("solver", "study", "workflows"):  # an editable install maps the folders: copy what they hold
        package = pathlib.Path(importlib.import_module(f"rimroll.{room}").__file__).resolve().parent
        if not (site / "rimroll" / room).is_dir():
            shutil.copytree(package, site / "rimroll" / room, ignore=shutil.ignore_patterns("__pycache__"))
    return site


def test_kernels_cached_by_another_install_path_do_not_count(tmp_path):
    """The check reads the index numba itself will read: this install's kernel is cached (the suite ran it),
    while a second install of the same sources beside it, sharing the cache folder, must compile its own."""
    import subprocess
    import sys

    solver.simulate([[1.1, 2.0, 35.0, 10.0]], solver.Params(mu=float("inf")), t_max=0.1, workers=1, method="dp5")
    here = subprocess.run([sys.executable, "-c", _PROBE], capture_output=True, text=True, cwd=tmp_path)
    site = _second_install(tmp_path)
    there = subprocess.run([sys.executable, "-c", _PROBE], capture_output=True, text=True, cwd=tmp_path,
                           env={**os.environ, "PYTHONPATH": str(site)})
    assert here.returncode == 0 and there.returncode == 0, here.stderr[-2000:] + there.stderr[-2000:]
    assert here.stdout.startswith("True ")
    assert there.stdout.startswith("False ") and there.stdout.split()[1].startswith(str(site))


def test_the_cache_index_of_the_scene_kernel_is_found_after_a_run():
    solver.simulate([[1.1, 2.0, 35.0, 10.0]], solver.Params(mu=float("inf")), t_max=0.1, method="dp5")
    assert any(_jit.cache_dir().glob("**/kernels.scene_rolling-*.nbi"))


def test_functions_taking_compiled_functions_are_not_cached_on_their_own():
    """Their cache key would name one process's function object (see solver._compile.engine_kernel)."""
    from rimroll.solver.engine import events, stepper

    for func in (kernels.run_phase, events.next_event, events.locate, events.minimum, events.value_at,
                 stepper.initial_step, stepper.dense_prepare, stepper.rk_step, stepper.attempt):
        assert type(func._cache).__name__ == "NullCache", func


_CHILD = ("import sys, time; from rimroll import solver; from rimroll.solver.engine import kernels\n"
          "t = time.perf_counter()\n"
          "solver.simulate([[1.1, 2.0, 35.0, 10.0]], solver.Params(mu=float(sys.argv[1]), k_r=float(sys.argv[2])),"
          " t_max=0.1, workers=1, method='dp5')\n"
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
        assert "first run of this install only" not in err
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
            "    solver.simulate([[1.1, 2.0, 35.0, 10.0]], solver.Params(mu=mu, k_r=k_r), t_max=0.1, workers=1,"
            " method='dp5')\n"
            "for s in kernels.run_phase.signatures:\n"
            "    print(str(s[0]).split('function ')[1].split(' ')[0])\n"
            "print([bool(k.signatures) for k in kernels.SCENE_KERNELS.values()])\n")
    env = {**os.environ, "RIMROLL_CACHE_DIR": str(tmp_path / "cache"), "RIMROLL_COMPILE_HERE": "1"}
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


_COLD = ("import logging, sys; logging.basicConfig(level=logging.INFO, format='%(message)s')\n"
         "from rimroll import solver\n"
         "solver.simulate([[1.1, 2.0, 35.0, 10.0]], solver.Params(mu=float('inf')), t_max=0.1, workers=1,"
         " method='dp5')\n")


@pytest.mark.slow
def test_ctrl_c_during_a_first_compile_stops_within_a_second(tmp_path):
    """The compile runs in a child process and the caller waits in steps of 0.2 s: SIGINT to the caller alone
    (not its process group) stops it, and the compile with it, within a second (numba in the caller's own
    thread held it until the compile ended, half a minute)."""
    import signal
    import subprocess
    import sys

    env = {**os.environ, "RIMROLL_CACHE_DIR": str(tmp_path / "cache")}
    proc = subprocess.Popen([sys.executable, "-c", _COLD], stderr=subprocess.PIPE, text=True, env=env, cwd=tmp_path)
    first = proc.stderr.readline()
    assert "compiling the simulation kernel of the rolling scene (dp5)" in first, first
    time.sleep(2.0)  # the child is compiling
    t0 = time.perf_counter()
    proc.send_signal(signal.SIGINT)
    proc.wait(timeout=30)
    assert time.perf_counter() - t0 < 1.0 and proc.returncode != 0
    left = subprocess.run(["pgrep", "-f", "rimroll.solver.engine.compiling"], capture_output=True, text=True)
    assert not [pid for pid in left.stdout.split() if _parent_of(pid) == proc.pid]


def _parent_of(pid: str) -> int | None:
    try:
        return int(pathlib.Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()[1])
    except (OSError, IndexError, ValueError):
        return None


@pytest.mark.slow
def test_a_second_install_beside_the_first_announces_its_own_compile(tmp_path):
    """Cold cache: the first process announces and compiles; a second process of the same install loads it
    silently; a second install (another path, same sources, same cache folder) announces its compile again,
    now with the time the first one took on this machine."""
    import subprocess
    import sys

    env = {**os.environ, "RIMROLL_CACHE_DIR": str(tmp_path / "cache")}

    def cold(**more):
        out = subprocess.run([sys.executable, "-c", _COLD], capture_output=True, text=True, cwd=tmp_path,
                             env={**env, **more}, timeout=600)
        assert out.returncode == 0, out.stderr[-2000:]
        return out.stderr

    first = cold()
    assert "first run of this install only: no earlier compile" in first and "compiled the rolling scene" in first
    assert "first run of this install only" not in cold()
    again = cold(PYTHONPATH=str(_second_install(tmp_path)))
    assert "first run of this install only: about" in again and "as its last compile on this machine" in again


def test_a_compile_in_this_process_is_announced_with_progress_and_its_time(monkeypatch, caplog, tmp_path):
    """``compiling.compile_here_announced`` (the exact rolling solver's compile, in the process that needs it):
    a notice before, a progress line every PROGRESS_EVERY s, the time after; nothing once compiled; and
    ``simulate(method="reduced")`` goes through it with the solver's numba kernel where the legs compiled at install
    are missing, and compiles nothing where they are there."""
    import logging

    from rimroll.solver.engine import compiling, reduced_compiled, reduced_legs, reduced_rolling

    monkeypatch.setenv("RIMROLL_CACHE_DIR", str(tmp_path))  # where the measured times are kept
    monkeypatch.setattr(compiling, "PROGRESS_EVERY", 0.02)
    compiled = set()
    monkeypatch.setattr(compiling, "is_compiled", lambda dispatcher, types: types in compiled)

    class Kernel:  # a stand-in for a numba dispatcher whose compile takes time
        def typeof_pyval(self, value):
            return numba.typeof(value)

        def compile(self, types):
            time.sleep(0.2)
            compiled.add(types)

    caplog.set_level(logging.INFO, "rimroll")
    compiling.compile_here_announced(Kernel(), (1.0, 2), "toy solver")
    said = [r.getMessage() for r in caplog.records]
    assert said[0].startswith("compiling the toy solver, first run of this install only: no earlier compile")
    assert any(m.startswith("still compiling the toy solver: ") for m in said[1:-1])
    assert said[-1].startswith("compiled the toy solver in ")
    caplog.clear()
    compiling.compile_here_announced(Kernel(), (1.0, 2), "toy solver")  # compiled: nothing to say
    assert caplog.records == []
    compiled.clear()  # another install: now with the time measured above
    compiling.compile_here_announced(Kernel(), (1.0, 2), "toy solver")
    assert "about 0 s, as its last compile on this machine" in caplog.records[0].getMessage()

    calls = []
    monkeypatch.setattr(compiling, "compile_here_announced", lambda d, args, name: calls.append((d, name)))
    state, scene = [[1.1, 1.17, 35.0, 10.0]], solver.Params(mu=float("inf"))
    solver.simulate(state, scene, method="reduced", workers=1)
    assert calls == []  # the legs compiled at install (solver/engine/_exact_legs.c): nothing to compile here
    monkeypatch.setattr(reduced_compiled, "legs", lambda: None)  # an install without a C compiler
    solver.simulate(state, scene, method="reduced", workers=1)
    assert calls and set(calls) == {(reduced_rolling.legs, reduced_legs.COMPILE_NAME)}  # one call a leg run


def test_the_python_version_of_a_kernel_compiles_nothing_and_equals_the_compiled_one():
    """``_jit.python_version`` runs a kernel and every kernel it calls as Python on numpy arrays: no kernel
    gains a compiled signature, and the values are those of the compiled kernels, state by state."""
    import numpy as np

    from rimroll.solver import Params, _jit
    from rimroll.solver.engine import rules
    from rimroll.solver.physics import rolling

    if _jit._DISABLE:
        return
    rng = np.random.default_rng(2)
    b, w1, w2, w3 = rng.uniform(0, 2, 40), rng.uniform(-5, 5, 40), rng.uniform(0, 90, 40), rng.uniform(-20, 20, 40)
    p = Params(mu=np.inf).as_array()
    kernels = (rules.rate_scale, rules.omega_scale, rolling.rolling_rhs, rules.transversal_omega1_zero)
    before = [len(k.signatures) for k in kernels]
    got = _jit.python_version(rules.transversal_omega1_zero)(b, 0.0, w2, w3, p, 1e-8)
    assert [len(k.signatures) for k in kernels] == before
    want = [rules.transversal_omega1_zero(*x, 0.0, *y, p, 1e-8) for x, y in zip(b[:, None], np.stack([w2, w3], -1))]
    np.testing.assert_array_equal(got, want)
    rates = _jit.python_version(rolling.rolling_rhs)(b, w1, w2, w3, p)
    for n in range(40):
        np.testing.assert_allclose([r[n] for r in rates], rolling.rolling_rhs(b[n], w1[n], w2[n], w3[n], p),
                                   rtol=1e-14, atol=0)
