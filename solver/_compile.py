"""Compilation policy of the integration kernels (stepper, events, scenes).

As ``solver._jit.physics_kernel`` (nopython, ``nogil``, no reference counting, cached on disk,
``RIMROLL_NO_JIT=1`` runs the Python source) but with numba's ``error_model="numpy"``: a division by zero gives inf/NaN,
which the kernels turn into a ``status`` code for that lane, instead of raising
``ZeroDivisionError`` out of a whole chunk of trajectories. No ``fastmath``: event location and
energy checks rely on IEEE arithmetic.

The disk cache lives in ``solver._jit.cache_dir()``: per user, and per digest of every ``.py``
file of ``solver/`` and its subpackages, so any change of any solver source recompiles every kernel.
"""

from __future__ import annotations

import numba

from rimroll.solver import _jit


def engine_kernel(func=None, *, inline=False, takes_functions=False, runtime=False):
    """Compile ``func`` with numba (nopython, nogil, cache, error_model="numpy").

    ``@engine_kernel(inline=True)`` marks a small function on the per-step hot path (the RK step and
    its right-hand side, the error norm and step factor, the grazing gate): numba inlines it
    into its callers at the IR level (``inline="always"``). LLVM does not inline these calls by
    itself (each array argument is passed as a struct of ~8 words), and the call overhead was
    ~20% of a rolling step. Inlined functions are still compiled (and callable) on their own.

    ``@engine_kernel(takes_functions=True)`` marks a function with a compiled function among its
    arguments (a phase's rhs or event function): it is not cached on disk by itself. numba keys
    its cache entries on the argument types, and the type of a function argument names one
    process's function object: such an entry never hits in another process, and re-saving the
    index with entries of a finished process can raise ``ReferenceError``. Its machine code is
    cached anyway, inside every cached kernel that calls it.

    Kernels are compiled without numba's runtime (``solver._jit.NO_REFCOUNT``: no reference
    counting, no allocation). ``@engine_kernel(runtime=True)`` keeps it for the functions that are also
    called with broadcast numpy arrays (the rules: the analysis of Theorem 1 calls them on arrays of
    states), where numba allocates the result.
    """
    if func is None:
        return lambda f: engine_kernel(f, inline=inline, takes_functions=takes_functions, runtime=runtime)
    if _jit._DISABLE:
        func.py_func = func
        return func
    options = dict(nogil=True, error_model="numpy", inline="always" if inline else "never")
    if not runtime:
        options.update(_jit.NO_REFCOUNT)
    if takes_functions:
        return numba.njit(cache=False, **options)(func)
    return _jit.njit_cached(func, **options)
