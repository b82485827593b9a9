"""The disk cache of compiled kernels never serves machine code of other solver sources."""

import numba.core.caching as caching

from solver import _jit, kernels, rolling


def test_solver_kernels_are_stamped_with_the_digest_of_all_solver_sources():
    for func in (rolling.rolling_rhs, kernels.run_chunk):
        locator = func._cache._impl.locator
        assert type(locator).__name__.startswith("RimrollSources")
        assert locator.get_source_stamp() == _jit.SOURCES_DIGEST


def test_other_packages_keep_numbas_own_locators():
    def outside(x):
        return x + 1

    for cls in caching.CacheImpl._locator_classes if hasattr(caching, "CacheImpl") else caching._CacheImpl._locator_classes:
        if cls.__name__.startswith("RimrollSources"):
            assert cls.from_function(outside, caching.__file__) is None


def test_digest_changes_when_any_solver_source_changes(tmp_path, monkeypatch):
    (tmp_path / "events.py").write_text("x = 1\n")
    (tmp_path / "kernels.py").write_text("y = 1\n")
    monkeypatch.setattr(_jit, "_SOURCES", tmp_path)
    before = _jit.sources_digest()
    assert _jit.sources_digest() == before
    (tmp_path / "events.py").write_text("x = 2\n")  # a callee edited: every kernel's stamp moves
    assert _jit.sources_digest() != before


def test_installing_the_stamp_twice_adds_no_second_set_of_locators():
    assert _jit._install_cache_stamp()
    impl = getattr(caching, "CacheImpl", None) or caching._CacheImpl
    names = [c.__name__ for c in impl._locator_classes if c.__name__.startswith("RimrollSources")]
    assert len(names) == len(set(names)) == 3
