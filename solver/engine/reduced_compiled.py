"""The exact rolling solver's legs compiled at install (``solver/engine/_exact_legs.c``), found and checked.

``reduced_rolling`` is the algorithm, as numba source; ``_exact_legs.c`` is the same algorithm in C,
built by ``pip install`` (pyproject.toml, ``ext-modules``) so that the exact solver compiles nothing
at run time. :func:`legs` returns a function with the arguments of ``reduced_rolling.legs`` less the
scratch arrays, or None when the library is missing (installed without a C compiler) or was built
for another layout of the tables (a stale build): ``reduced_legs`` then runs the numba kernel, whose
first compile it announces. The call goes through ctypes, which releases the GIL, so threads run
chunks of jobs at once.
"""

from __future__ import annotations

import ctypes
import functools
import importlib.util

import numpy as np

from rimroll.solver.engine import reduced_rolling as rr
from rimroll.solver.engine import reduced_tables as rt

LAYOUT = (rt.N_COEF, rt.N_NODES, rt.N_FUNCTIONS, len(rt.NODE_FUNCTIONS), len(rt.SPREAD_FUNCTIONS), rr.N_J, rr.N_O,
          rr.N_C, rr.N_RULE, rt.Q11, rt.Q12, rt.Q22, rt.S11, rt.S12, rt.S22, rt.SIN, rt.G21, rt.G22, rr.MAX_STACK,
          rr.MAX_MARCH, rr.MAX_QUAD, rr.MAX_NEWTON)
"""The array shapes, table rows and caps the library must have been compiled with, in its order."""
TOLERANCES = (rr.H_MIN, rr.QUAD_RTOL, rr.NEAR)
_NAME = "rimroll.solver.engine._exact_legs"
_DOUBLES = ctypes.POINTER(ctypes.c_double)


@functools.lru_cache(maxsize=1)
def library() -> ctypes.CDLL | None:
    """The compiled library, or None where it is not installed or its layout or tolerances differ from this
    source's (``reduced_rolling``, ``reduced_tables``)."""
    try:
        spec = importlib.util.find_spec(_NAME)
    except ImportError:
        return None
    if spec is None or not spec.origin or not spec.origin.endswith((".so", ".pyd", ".dylib")):
        return None
    try:
        lib = ctypes.CDLL(spec.origin)
        dims = (ctypes.c_long * 64)()
        n = lib.rimroll_exact_layout(dims, 64)
        tols = (ctypes.c_double * 8)()
        lib.rimroll_exact_tolerances.argtypes = [ctypes.POINTER(ctypes.c_double), ctypes.c_int]
        k = lib.rimroll_exact_tolerances(tols, 8)
    except (OSError, AttributeError):  # not loadable, or built from an older source without these functions
        return None
    if tuple(dims[:n]) != LAYOUT or tuple(tols[:k]) != TOLERANCES:
        return None
    lib.rimroll_exact_legs.restype = ctypes.c_int
    lib.rimroll_exact_legs.argtypes = [ctypes.c_long] + [_DOUBLES] * 7
    lib.rimroll_exact_evaluate.restype = ctypes.c_int
    lib.rimroll_exact_evaluate.argtypes = [ctypes.c_long, _DOUBLES, _DOUBLES, ctypes.c_long, ctypes.c_double,
                                           ctypes.c_double, ctypes.POINTER(ctypes.c_long), ctypes.c_int, _DOUBLES]
    return lib


def _pointer(a: np.ndarray, shape_tail: tuple, name: str):
    if a.dtype != np.float64 or not a.flags.c_contiguous or a.shape[1:] != shape_tail:
        raise ValueError(f"{name}: need a C-contiguous float64 array of shape (n,) + {shape_tail}; got {a.dtype} "
                         f"{a.shape}")
    return a.ctypes.data_as(_DOUBLES)


def legs():
    """``legs(jobs, tab, nod, spread, c, rule, out)``: the legs of the job rows (m, N_J) into out (m, N_O) by the
    compiled library (arguments as ``reduced_rolling.legs``, without its scratch arrays); None without the library."""
    lib = library()
    if lib is None:
        return None

    def run(jobs, tab, nod, spread, c, rule, out):
        n_pan = tab.shape[0]
        if out.shape[0] != jobs.shape[0]:
            raise ValueError(f"out has {out.shape[0]} rows for {jobs.shape[0]} jobs")
        if nod.shape[0] != n_pan or spread.shape[0] != n_pan or int(c[rr.C_NPAN]) != n_pan:
            raise ValueError("tab, nod, spread and c[C_NPAN] disagree on the number of panels")
        args = (_pointer(jobs, (rr.N_J,), "jobs"), _pointer(tab, (rt.N_FUNCTIONS, rt.N_COEF), "tab"),
                _pointer(nod, (len(rt.NODE_FUNCTIONS), rt.N_NODES), "nod"),
                _pointer(spread, (len(rt.SPREAD_FUNCTIONS),), "spread"), _pointer(c.reshape(1, -1), (rr.N_C,), "c"),
                _pointer(rule.reshape(1, -1), (rr.N_RULE * rt.N_NODES,), "rule"), _pointer(out, (rr.N_O,), "out"))
        if lib.rimroll_exact_legs(jobs.shape[0], *args) != 0:
            raise MemoryError("the exact rolling legs could not allocate their scratch space")

    return run


def evaluate_many(table: rt.Table, beta, functions) -> np.ndarray:
    """``reduced_tables.evaluate_many`` (values (len(functions), n) of tabled functions at beta (n,) [rad]) by the
    compiled library where it is installed (a loop in C: no gathered copies of the coefficients)."""
    lib = library()
    if lib is None:
        return rt.evaluate_many(table, beta, functions)
    beta = np.ascontiguousarray(beta, dtype=float).reshape(-1)
    funcs = np.asarray(functions, dtype=np.int_)
    if funcs.ndim != 1 or funcs.size == 0 or funcs.min() < 0 or funcs.max() >= rt.N_FUNCTIONS:
        raise ValueError(f"functions: need table rows in 0..{rt.N_FUNCTIONS - 1}; got {functions!r}")
    tab = np.ascontiguousarray(table.values)
    out = np.empty((funcs.size, beta.size))
    lib.rimroll_exact_evaluate(beta.size, beta.ctypes.data_as(_DOUBLES), tab.ctypes.data_as(_DOUBLES), tab.shape[0],
                               table.beta_lo, table.width, funcs.ctypes.data_as(ctypes.POINTER(ctypes.c_long)),
                               funcs.size, out.ctypes.data_as(_DOUBLES))
    return out
