"""The one compilation policy of rimroll's kernels.

``physics_kernel`` compiles a pure physics function with numba (``nogil`` so dask threads run kernels in
parallel, cached on disk so a fresh process loads machine code instead of recompiling: in a
per-user directory keyed on all solver sources, see :func:`cache_dir`). The physics functions
are written with numpy ufuncs and arithmetic only, so the original Python function
(``f.py_func``) also broadcasts over numpy arrays: the compiled scalar version serves the
integrator, ``vectorised(f)`` serves maps and users.
"""

from __future__ import annotations

import functools
import hashlib
import logging
import os
import pathlib
import pickle
import threading
import types

import numba
import numpy as np

_DISABLE = os.environ.get("RIMROLL_NO_JIT", "") not in ("", "0")

NO_REFCOUNT = {"_nrt": False}
"""numba option of the engine's kernels (``solver._compile.engine_kernel``): compile without numba's runtime
(NRT). With it, every array view made and every array a function receives costs an atomic increment
and decrement of its owner's reference count: 55-60 % of the engine's time on the Fig. 11 section
went to those two instructions (``perf`` of the section), and the section ran 2-2.4x slower. The
engine allocates nothing (its work arrays are made by ``simulate`` in Python and live while the
kernel runs), which is all the runtime is needed for; the CUDA target has no runtime either, so
the one source compiles alike for both. The physics kernels (:func:`physics_kernel`) keep the runtime: they
take and return numbers, and called with numpy arrays they build the broadcast result."""
_SOURCES = pathlib.Path(__file__).resolve().parent


def sources_digest() -> str:
    """sha256 of every ``.py`` file of the solver package and its subpackages (paths, contents), once per process."""
    digest = hashlib.sha256()
    for path in sorted(_SOURCES.rglob("*.py")):
        digest.update(path.relative_to(_SOURCES).as_posix().encode() + b"\0" + path.read_bytes())
    return digest.hexdigest()


SOURCES_DIGEST = sources_digest()


def cache_dir() -> pathlib.Path:
    """Directory of the on-disk machine code of rimroll's kernels [a path].

    Per user and per solver sources: ``$RIMROLL_CACHE_DIR`` if set, else
    ``$XDG_CACHE_HOME/rimroll`` (default ``~/.cache/rimroll``), then ``numba-<digest>`` with the
    first 16 hex digits of ``SOURCES_DIGEST``. numba stamps each cached function with its own
    source file only; a directory per digest of *all* solver sources means a kernel never loads
    machine code compiled against another version of a module it calls, and nothing is ever
    written into the installed package.
    """
    root = os.environ.get("RIMROLL_CACHE_DIR")
    if root:
        base = pathlib.Path(root)
    else:
        xdg = os.environ.get("XDG_CACHE_HOME")
        base = (pathlib.Path(xdg) if xdg else pathlib.Path.home() / ".cache") / "rimroll"
    return base / f"numba-{SOURCES_DIGEST[:16]}"


_CACHE_DIR_LOCK = threading.RLock()
_DAMAGE = (pickle.UnpicklingError, EOFError, ValueError, TypeError, AttributeError, ImportError, IndexError,
           KeyError, OverflowError, MemoryError)
"""What unpickling a damaged cache file raises (garbage bytes: UnicodeDecodeError, a ValueError; a file cut
short: EOFError; a length read from garbage: MemoryError)."""


class _RebuildDamaged:
    """numba's disk cache of one kernel, through which a damaged entry (its index or machine-code file
    unreadable) is rebuilt with one warning instead of failing the call: the entry's index is removed, so
    numba compiles the kernel again and saves a fresh entry."""

    def __init__(self, cache, name: str):
        self._cache, self._name = cache, name

    def __getattr__(self, attr):
        return getattr(self._cache, attr)

    def load_overload(self, sig, target_context):
        try:
            return self._cache.load_overload(sig, target_context)
        except _DAMAGE as exc:
            index = pathlib.Path(self._cache._cache_file._index_path)
            index.unlink(missing_ok=True)
            logging.getLogger(__name__).warning(
                "the kernel cache entry of %s in %s is damaged (%s); rebuilding it (compiles again)", self._name,
                index.parent, type(exc).__name__)
            return None


def njit_cached(func, **options):
    """``numba.njit(cache=True, **options)(func)`` with its disk cache in :func:`cache_dir`.

    numba chooses a function's cache location when it is decorated, from its public setting
    ``numba.config.CACHE_DIR``; that setting is pointed at :func:`cache_dir` for the decoration
    only and restored at once, so other numba code keeps its own cache location. The setting is global:
    a lock keeps two threads from decorating at once, where one thread's restore could land between
    numba's check of the setting and its use, and numba would put that function's cache in a folder
    of the current directory (``scenes_<sha1>/``).
    """
    with _CACHE_DIR_LOCK:  # threads that decorate at once (a scene module imported from two dask threads)
        previous = numba.config.CACHE_DIR
        numba.config.CACHE_DIR = str(cache_dir())
        try:
            dispatcher = numba.njit(cache=True, **options)(func)
        finally:
            numba.config.CACHE_DIR = previous
    dispatcher._cache = _RebuildDamaged(dispatcher._cache, func.__name__)
    return dispatcher


def physics_kernel(func=None, *, inline=False):
    """Compile a physics function ``func`` with numba in nopython mode, nogil, cached on disk, with numba's
    runtime and its Python error model (a division by zero raises): it takes and returns numbers, and its
    Python source broadcasts over numpy arrays (:func:`vectorised`).

    ``@physics_kernel(inline=True)``: numba inlines it into its callers (``inline="always"``), for the small
    helpers every equation calls (``params.constants``). Set the environment variable ``RIMROLL_NO_JIT=1`` to
    run the pure-Python source instead (for debugging; slow).
    """
    if func is None:
        return lambda f: physics_kernel(f, inline=inline)
    if _DISABLE:
        func.py_func = func
        return func
    return njit_cached(func, nogil=True, inline="always" if inline else "never")


def vectorised(func):
    """A numpy-broadcasting version of a physics kernel (its pure-Python source)."""
    py = getattr(func, "py_func", func)

    @functools.wraps(py)
    def wrapper(*args):
        with np.errstate(divide="ignore", invalid="ignore"):
            return py(*args)

    return wrapper


_PYTHON_VERSIONS: dict = {}


def python_version(func):
    """The pure-Python source of a compiled kernel with every kernel it calls (directly or through a rimroll
    module) replaced by its own pure-Python source, recursively, so that a call with numpy arrays broadcasts
    without compiling anything. (:func:`vectorised` runs the top function's source only: the kernels it calls
    are compiled again for array arguments, seconds on a first run.) Wrapped like :func:`vectorised`."""
    pure = _python(func)

    @functools.wraps(pure)
    def wrapper(*args, **kwargs):
        with np.errstate(divide="ignore", invalid="ignore"):
            return pure(*args, **kwargs)

    return wrapper


class _PythonModule:
    """A rimroll module whose compiled kernels are seen as their pure-Python versions."""

    def __init__(self, module):
        self._module = module

    def __getattr__(self, name):
        return _python(getattr(self._module, name))


def _python(obj):
    if isinstance(obj, types.ModuleType):
        return _PythonModule(obj) if obj.__name__.startswith("rimroll.") else obj
    if not isinstance(obj, numba.core.dispatcher.Dispatcher) and not hasattr(obj, "py_func"):
        return obj
    py = obj.py_func
    if py not in _PYTHON_VERSIONS:
        scope = {}
        twin = types.FunctionType(py.__code__, scope, py.__name__, py.__defaults__, py.__closure__)
        twin.__kwdefaults__ = py.__kwdefaults__
        _PYTHON_VERSIONS[py] = twin
        scope.update({name: _python(value) if _compiled_or_module(value) else value
                      for name, value in py.__globals__.items()})
    return _PYTHON_VERSIONS[py]


def _compiled_or_module(value) -> bool:
    return (isinstance(value, numba.core.dispatcher.Dispatcher)
            or (isinstance(value, types.ModuleType) and value.__name__.startswith("rimroll.")))
