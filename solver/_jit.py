"""The one compilation policy of rimroll's kernels.

``kernel`` compiles a pure function with numba (``nogil`` so dask threads run kernels in
parallel, ``cache=True`` so a fresh process loads machine code from disk instead of
recompiling). The physics functions are written with numpy ufuncs and arithmetic only, so
the original Python function (``f.py_func``) also broadcasts over numpy arrays: the
compiled scalar version serves the integrator, ``vectorised(f)`` serves maps and users.
"""

from __future__ import annotations

import functools
import hashlib
import os
import pathlib

import numba
import numpy as np

_DISABLE = os.environ.get("RIMROLL_NO_JIT", "") not in ("", "0")
_SOURCES = pathlib.Path(__file__).resolve().parent
_STAMP = "rimroll-solver-sources.sha256"


def _cache_dir() -> pathlib.Path:
    """The directory where numba caches machine code of functions defined in ``solver/``."""
    try:
        from numba.core.caching import _CacheImpl

        for locator_cls in _CacheImpl._locator_classes:
            locator = locator_cls.from_function(_cache_dir, str(_SOURCES / "_jit.py"))
            if locator is not None:
                return pathlib.Path(locator.get_cache_path())
    except Exception:  # a private numba API: fall back to numba's usual in-tree location
        pass
    return _SOURCES / "__pycache__"


def invalidate_stale_cache() -> bool:
    """Drop cached machine code compiled from other versions of ``solver/*.py``; True if dropped.

    numba keys its disk cache on the source file of each compiled function only, so a kernel
    would keep running the old code of an edited (or upgraded) module it calls. A hash of all
    solver sources, stamped beside the cache, detects that; the cache is then emptied once.
    """
    digest = hashlib.sha256()
    for path in sorted(_SOURCES.glob("*.py")):
        digest.update(path.name.encode() + b"\0" + path.read_bytes())
    cache = _cache_dir()
    stamp = cache / _STAMP
    try:
        if stamp.read_text() == digest.hexdigest():
            return False
    except OSError:
        pass
    try:
        cache.mkdir(parents=True, exist_ok=True)
        for pattern in ("*.nbi", "*.nbc"):
            for stale in cache.glob(pattern):
                stale.unlink(missing_ok=True)
        stamp.write_text(digest.hexdigest())
    except OSError:  # read-only install: numba then caches elsewhere or not at all
        return False
    return True


if not _DISABLE:
    invalidate_stale_cache()


def kernel(func):
    """Compile ``func`` with numba in nopython mode, nogil, cached on disk.

    Set the environment variable ``RIMROLL_NO_JIT=1`` to run the pure-Python source
    instead (for debugging; slow).
    """
    if _DISABLE:
        func.py_func = func
        return func
    return numba.njit(cache=True, nogil=True)(func)


def vectorised(func):
    """A numpy-broadcasting version of a physics kernel (its pure-Python source)."""
    py = getattr(func, "py_func", func)

    @functools.wraps(py)
    def wrapper(*args):
        with np.errstate(divide="ignore", invalid="ignore"):
            return py(*args)

    return wrapper
