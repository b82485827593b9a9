"""The disk cache of compiled kernels: per user, per digest of all solver sources, never inside
the package, and without touching numba's own cache location for other code."""

import os
import pathlib

import numba

import solver
from solver import _jit, kernels, rolling


def test_solver_kernels_cache_in_the_per_user_directory_of_the_sources_digest():
    package = pathlib.Path(solver.__file__).resolve().parent
    for func in (rolling.rolling_rhs, kernels.run_chunk):
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


def test_a_first_compile_is_announced_on_stderr_once(monkeypatch, capsys):
    import importlib

    simulate_module = importlib.import_module("solver.simulate")  # the module, not the function

    monkeypatch.setattr(simulate_module, "kernels_cached", lambda scene=None: False)
    monkeypatch.setattr(simulate_module, "_announced", set())
    x = [[1.1, 2.0, 35.0, 10.0]]
    solver.simulate(x, solver.Params(mu=float("inf")), t_max=0.1)
    solver.simulate(x, solver.Params(mu=float("inf")), t_max=0.1)
    err = capsys.readouterr().err
    assert err.count("first run only") == 1
    assert "rolling_conservative scene" in err
    assert str(_jit.cache_dir()) in err
    solver.simulate(x, solver.Params(mu=1.0), t_max=0.1)  # another scene: its own line
    err = capsys.readouterr().err
    assert err.count("first run only") == 1 and "hybrid_conservative scene" in err


def test_the_cache_index_of_the_chunk_driver_is_found_after_a_run():
    from solver import simulate as run

    run([[1.1, 2.0, 35.0, 10.0]], solver.Params(mu=float("inf")), t_max=0.1)
    assert any(_jit.cache_dir().glob("**/kernels.run_chunk-*.nbi"))
    assert any(_jit.cache_dir().glob("**/kernels.trajectory_rolling_conservative-*.nbi"))


def _cached_signatures(dispatcher):
    """The signatures in a kernel's on-disk cache index (numba's own index file)."""
    index = dispatcher._cache._cache_file._load_index()
    return [key[0] for key in index]


def test_the_step_loop_is_compiled_three_times_for_the_four_scenes():
    """run_phase is the costly part of the first compile: rolling with and without the friction
    cone, slipping once (only hybrid scenes slip); never once per scene and phase (eight)."""
    x = [[1.1, 2.0, 35.0, 10.0]]
    for mu, k_r in ((float("inf"), 0.0), (float("inf"), 0.02), (1.0, 0.0), (1.0, 0.02)):
        solver.simulate(x, solver.Params(mu=mu, k_r=k_r), t_max=0.1)
    sigs = _cached_signatures(kernels.run_phase)
    assert len(sigs) == 3, sigs
    flags = sorted((str(s[0]).split("function ")[1].split(" ")[0], str(s[3])) for s in sigs)
    assert flags == [("rolling_rhs", "Literal[bool](False)"), ("rolling_rhs", "Literal[bool](True)"),
                     ("slipping_rhs", "Literal[bool](True)")]


def test_a_rolling_only_process_compiles_no_slipping_kernel(tmp_path):
    """A scene's kernel is compiled when that scene first runs, and a rolling-only kernel holds no
    slipping phase (it loads from the shared cache here; the check is on what the process built)."""
    import subprocess
    import sys

    code = ("import solver; from solver import kernels\n"
            "solver.simulate([[1.1, 2.0, 35.0, 10.0]], solver.Params(mu=float('inf')), t_max=0.1)\n"
            "print([bool(k.signatures) for k in kernels.SCENE_KERNELS])\n")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True,
                         cwd=tmp_path, env={**os.environ, "PYTHONPATH": str(pathlib.Path(solver.__file__).parents[1])})
    assert out.stdout.strip() == "[True, False, False, False]"
