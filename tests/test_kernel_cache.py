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

    monkeypatch.setattr(simulate_module, "kernels_cached", lambda: False)
    monkeypatch.setattr(simulate_module, "_announced", False)
    x = [[1.1, 2.0, 35.0, 10.0]]
    solver.simulate(x, solver.Params(mu=float("inf")), t_max=0.1)
    solver.simulate(x, solver.Params(mu=float("inf")), t_max=0.1)
    err = capsys.readouterr().err
    assert err.count("compiling the simulation kernels, first run only") == 1
    assert str(_jit.cache_dir()) in err


def test_the_cache_index_of_the_chunk_driver_is_found_after_a_run():
    from solver import simulate as run

    run([[1.1, 2.0, 35.0, 10.0]], solver.Params(mu=float("inf")), t_max=0.1)
    assert any(_jit.cache_dir().glob("**/kernels.run_chunk-*.nbi"))
