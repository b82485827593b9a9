"""The one compilation policy of rimroll's kernels.

``kernel`` compiles a pure function with numba (``nogil`` so dask threads run kernels in
parallel, ``cache=True`` so a fresh process loads machine code from disk instead of
recompiling). The physics functions are written with numpy ufuncs and arithmetic only, so
the original Python function (``f.py_func``) also broadcasts over numpy arrays: the
compiled scalar version serves the integrator, ``vectorised(f)`` serves maps and users.
"""

from __future__ import annotations

import functools
import os

import numba
import numpy as np

_DISABLE = os.environ.get("RIMROLL_NO_JIT", "") not in ("", "0")


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
