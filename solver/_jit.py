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


def sources_digest() -> str:
    """sha256 of every ``solver/*.py`` (names and contents), read once per process."""
    digest = hashlib.sha256()
    for path in sorted(_SOURCES.glob("*.py")):
        digest.update(path.name.encode() + b"\0" + path.read_bytes())
    return digest.hexdigest()


SOURCES_DIGEST = sources_digest()


def _install_cache_stamp() -> bool:
    """Make numba's disk cache of solver kernels depend on ALL solver sources.

    numba stamps each cached function with a hash of its own source file only, so a kernel
    would keep the old machine code of an edited (or upgraded) module it calls. For functions
    defined in ``solver/``, numba's usual cache locations are used with the stamp replaced by
    ``SOURCES_DIGEST``, taken when this process imported the sources: an index written from
    other sources never matches and is recompiled, and a process still running older sources
    can only write entries stamped with its own, older digest (no race). Returns False if
    numba's (private) locator API is not as expected; then numba's own per-file stamp applies.
    """
    try:
        from numba.core import caching

        bases = (caching.UserProvidedCacheLocator, caching.InTreeCacheLocator, caching.UserWideCacheLocator)
        impl = getattr(caching, "CacheImpl", None) or caching._CacheImpl  # renamed in numba 0.6x
        impl_locators = impl._locator_classes
    except (ImportError, AttributeError):
        return False

    def solver_locator(base):
        class Locator(base):
            def get_source_stamp(self):
                return SOURCES_DIGEST

            @classmethod
            def from_function(cls, py_func, py_file):
                if pathlib.Path(py_file).resolve().parent != _SOURCES:
                    return None
                return super().from_function(py_func, py_file)

        Locator.__name__ = Locator.__qualname__ = f"RimrollSources{base.__name__}"
        return Locator

    if not any(getattr(c, "__name__", "").startswith("RimrollSources") for c in impl_locators):
        impl_locators[:0] = [solver_locator(base) for base in bases]
    return True


if not _DISABLE:
    _install_cache_stamp()


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
