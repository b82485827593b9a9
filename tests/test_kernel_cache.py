"""The disk cache of compiled kernels never serves machine code of other solver sources."""

from solver import _jit


def test_cache_is_emptied_exactly_when_a_solver_source_changes(tmp_path, monkeypatch):
    src, cache = tmp_path / "solver", tmp_path / "cache"
    src.mkdir()
    cache.mkdir()
    (src / "events.py").write_text("x = 1\n")
    monkeypatch.setattr(_jit, "_SOURCES", src)
    monkeypatch.setattr(_jit, "_cache_dir", lambda: cache)

    def cached(name):
        (cache / f"{name}.nbi").write_text("index")
        (cache / f"{name}.1.nbc").write_text("code")

    cached("kernels.trajectory-1.py311")
    assert _jit.invalidate_stale_cache() is True  # no stamp yet: unknown provenance, dropped
    assert not list(cache.glob("*.nb*"))
    cached("kernels.trajectory-1.py311")
    assert _jit.invalidate_stale_cache() is False  # same sources: the cache is kept
    assert len(list(cache.glob("*.nb*"))) == 2
    (src / "events.py").write_text("x = 2\n")  # a callee edited: callers' code is stale
    assert _jit.invalidate_stale_cache() is True
    assert not list(cache.glob("*.nb*"))
