"""The first compile of a scene kernel: known in advance, said, timed, and run where Ctrl-C stops it.

Whether numba will compile is decided as numba decides it: the kernel is compiled in this process
for these argument types (``dispatcher.overloads``), or its cache index (the ``.nbi`` file of *this*
source file, whose name and folder follow the source file's path) holds the key numba will look up
(the argument types, the machine, the function's bytecode; ``numba.core.caching.Cache._index_key``)
with the source file's stamp. Kernels cached by another install of rimroll (another virtual
environment, a checkout beside an installed copy) live under another path and do not count.

A kernel that must be compiled is said once (logging, INFO, logger ``rimroll.solver...``), with the
time its last compile took on this machine when one was measured (no estimate otherwise), then
compiled in a child process (``python -m rimroll.solver.engine.compiling``) that writes it into
the disk cache, from which this process loads it. While it runs, a line every
:data:`PROGRESS_EVERY` seconds says how long it has taken; Ctrl-C (or SIGTERM) stops the child
at once (it keeps numba's default action for both) instead of after the compile. Threads that
need different kernels (the scenes of a study, on a pool of threads) compile them in as many
processes at once. Where the child cannot compile it (a scene term registered only in this
process), or with the environment variable ``RIMROLL_COMPILE_HERE=1`` (to profile a compile), the
kernel is compiled in this process, as numba would have.
"""

from __future__ import annotations

import contextlib
import json
import logging
import os
import pickle
import signal
import socket
import subprocess
import sys
import threading
import time

from rimroll.solver import _jit
from rimroll.solver.engine import scene_code
from rimroll.solver.engine.scenes import Scene
from rimroll.solver.engine.tableaus import TABLEAUS

PROGRESS_EVERY = 10.0
"""Seconds between the lines that say a compile is still running."""
TIMES_FILE = "compile-seconds.json"
"""File, in the folder above each sources digest's cache, of the measured compile times of this user's kernels,
per machine: the estimate of the next first compile (after an update of rimroll too)."""

_HERE = os.environ.get("RIMROLL_COMPILE_HERE", "") not in ("", "0")
_log = logging.getLogger(__name__)
_LOCKS: dict = {}
_LOCKS_LOCK = threading.Lock()
_CHILDREN: set = set()  # the compiling children of this process, for stop_all


class CompileInterrupted(RuntimeError):
    """The child process compiling a kernel was stopped by a signal (Ctrl-C or SIGTERM to the group)."""


def argument_types(dispatcher, args) -> tuple:
    """The numba types of ``args`` as the dispatcher will type them on a call (its compile signature)."""
    return tuple(dispatcher.typeof_pyval(a) for a in args)


def is_compiled(dispatcher, types: tuple) -> bool:
    """Whether a call with ``types`` finds its machine code without compiling: compiled in this process,
    or in the disk cache index that this dispatcher's source file (this install's path and stamp) reads."""
    if tuple(types) in dispatcher.overloads:
        return True
    cache = getattr(dispatcher, "_cache", None)
    try:
        key = cache._index_key(tuple(types), dispatcher.targetctx.codegen())
        return key in cache._cache_file._load_index()
    except (AttributeError, OSError, EOFError, pickle.UnpicklingError, TypeError, ValueError):
        return False  # no disk cache (NullCache), or one this numba reads otherwise: it may compile


def label(scene: Scene, method) -> str:
    """What a reader calls the kernel of ``scene`` run with the stepper record ``method``: the scene, its load
    terms and the method's name (e.g. "hybrid + air_drag scene (dp5)")."""
    names = [name for name, t in TABLEAUS.items() if t.method.n_stages == method.n_stages
             and t.method.A.shape == method.A.shape]
    loads = "".join(f" + {t.name}" for t in scene.loads)
    return f"{scene.kernel.removeprefix('scene_')}{loads} scene ({names[0] if names else 'method'})"


def ensure_compiled(scene: Scene, method, args) -> None:
    """Make the kernel of ``scene`` callable with ``args`` (the arguments of the scene kernel) without a silent
    compile: nothing when it is compiled or cached for this install; else a notice, then its compile in a child
    process (this process then loads it from the disk cache), a progress line every :data:`PROGRESS_EVERY` s.

    Raises :class:`CompileInterrupted` when a signal stopped the child (in the main thread Ctrl-C is a
    ``KeyboardInterrupt`` and the child is stopped with it)."""
    if _jit._DISABLE:
        return
    dispatcher = scene_code.kernel_of(scene)
    types = argument_types(dispatcher, args)
    with _lock_of(scene, types):
        if is_compiled(dispatcher, types):
            return
        name = label(scene, method)
        measured = _measured().get(_time_key(name))
        _log.info("compiling the simulation kernel of the %s, first run of this install only: %s (cached in %s)",
                  name, f"about {measured:.0f} s, as its last compile on this machine" if measured else
                  "no earlier compile on this machine to estimate from", _jit.cache_dir())
        t0 = time.perf_counter()
        compiled = not _HERE and _compile_in_child(scene, types, name, t0) and is_compiled(dispatcher, types)
        if not compiled:  # the child could not rebuild this kernel: numba compiles it here
            dispatcher.compile(types)
        seconds = time.perf_counter() - t0
        _record(name, seconds)
        _log.info("compiled the %s kernel in %.0f s", name, seconds)


def compile_here_announced(dispatcher, args, name: str) -> None:
    """Make ``dispatcher`` callable with ``args`` without a silent compile, in this process (a kernel
    that compiles in seconds, such as the exact rolling solver's): nothing when it is compiled or cached
    for this install; else the notices of :func:`ensure_compiled` (one before, with the time its last
    compile took here; a progress line every :data:`PROGRESS_EVERY` s; the time after)."""
    if _jit._DISABLE:
        return
    types = argument_types(dispatcher, args)
    with _LOCKS_LOCK:
        lock = _LOCKS.setdefault((name, str(types)), threading.Lock())
    with lock:
        if is_compiled(dispatcher, types):
            return
        measured = _measured().get(_time_key(name))
        _log.info("compiling the %s, first run of this install only: %s (cached in %s)", name,
                  f"about {measured:.0f} s, as its last compile on this machine" if measured else
                  "no earlier compile on this machine to estimate from", _jit.cache_dir())
        t0 = time.perf_counter()
        done = threading.Event()

        def progress():
            while not done.wait(PROGRESS_EVERY):
                _log.info("still compiling the %s: %.0f s so far", name, time.perf_counter() - t0)

        ticker = threading.Thread(target=progress, name="rimroll-compile-progress", daemon=True)
        ticker.start()
        try:
            dispatcher.compile(types)
        finally:
            done.set()
            ticker.join()
        seconds = time.perf_counter() - t0
        _record(name, seconds)
        _log.info("compiled the %s in %.0f s", name, seconds)


def _lock_of(scene: Scene, types: tuple) -> threading.Lock:
    """One lock per kernel and signature: threads that need the same kernel wait for one compile."""
    key = (scene.kernel, tuple(t.name for t in scene.loads), str(types))
    with _LOCKS_LOCK:
        return _LOCKS.setdefault(key, threading.Lock())


def _compile_in_child(scene: Scene, types: tuple, name: str, t0: float) -> bool:
    """Compile the kernel in a child process, waiting in steps of at most 0.2 s (a progress line every
    :data:`PROGRESS_EVERY` s); False when the child could not (this process compiles it then)."""
    try:
        request = pickle.dumps((scene, types))
    except (pickle.PicklingError, TypeError, AttributeError):
        return False
    env = {**os.environ, "PYTHONPATH": os.pathsep.join(p for p in sys.path if p)}  # the same rimroll
    child = subprocess.Popen([sys.executable, "-m", __name__], stdin=subprocess.PIPE, stdout=subprocess.DEVNULL,
                             stderr=subprocess.PIPE, env=env)
    with _LOCKS_LOCK:
        _CHILDREN.add(child)
    try:
        _feed(child, request)
        said = t0
        while child.poll() is None:
            with contextlib.suppress(subprocess.TimeoutExpired):
                child.wait(timeout=0.2)
            if time.perf_counter() - said >= PROGRESS_EVERY:
                said = time.perf_counter()
                _log.info("still compiling the %s kernel: %.0f s so far", name, said - t0)
    except BaseException:
        _stop(child)
        raise
    finally:
        with _LOCKS_LOCK:
            _CHILDREN.discard(child)
    err = child.stderr.read().decode(errors="replace").strip()
    child.stderr.close()
    if child.returncode < 0:  # Ctrl-C or SIGTERM to the process group, stop_all (SIGKILL)
        stopped_by = signal.Signals(-child.returncode).name
        raise CompileInterrupted(f"the compile of the {name} kernel was stopped ({stopped_by})")
    if child.returncode != 0:
        _log.debug("the child process could not compile the %s kernel (%s); compiling it here", name, err[-500:])
    return child.returncode == 0


def stop_all() -> None:
    """Stop every compile this process's threads wait for (a run interrupted in its main thread, whose
    threads would otherwise wait for the compiles to end): each waiting thread raises
    :class:`CompileInterrupted` at once."""
    with _LOCKS_LOCK:
        children = list(_CHILDREN)
    for child in children:
        with contextlib.suppress(OSError):
            child.kill()


def _feed(child: subprocess.Popen, request: bytes) -> None:
    """Hand the request to the child (a child that died at once is seen by its exit status)."""
    with contextlib.suppress(BrokenPipeError):
        child.stdin.write(request)
    with contextlib.suppress(BrokenPipeError):
        child.stdin.close()


def _stop(child: subprocess.Popen) -> None:
    """Stop a compiling child now (this process was interrupted)."""
    with contextlib.suppress(OSError):
        child.kill()
    with contextlib.suppress(OSError, subprocess.TimeoutExpired):
        child.wait(timeout=5)
    for stream in (child.stdin, child.stderr):
        with contextlib.suppress(OSError):
            stream.close()


def _time_key(name: str) -> str:
    """The key of a kernel's measured compile time: the machine and the kernel."""
    return f"{socket.gethostname()}: {name}"


def _times_path():
    return _jit.cache_dir().parent / TIMES_FILE


def _measured() -> dict:
    """The measured compile times [s] by :func:`_time_key` (empty when none or unreadable)."""
    with contextlib.suppress(OSError, ValueError):
        found = json.loads(_times_path().read_text(encoding="utf-8"))
        if isinstance(found, dict):
            return {k: float(v) for k, v in found.items() if isinstance(v, (int, float)) and v > 0}
    return {}


def _record(name: str, seconds: float) -> None:
    """Keep this compile's time [s] for the next estimate (a file that cannot be written is no error)."""
    times = {**_measured(), _time_key(name): round(seconds, 1)}
    path = _times_path()
    with contextlib.suppress(OSError):
        path.parent.mkdir(parents=True, exist_ok=True)
        tmp = path.with_name(f".{path.name}.{os.getpid()}.tmp")
        tmp.write_text(json.dumps(times, indent=1, sort_keys=True), encoding="utf-8")
        os.replace(tmp, path)


def _child_main() -> int:
    """The child: read (scene, types) from stdin, compile that kernel into the disk cache, exit 0.
    Ctrl-C and SIGTERM keep their default action: the compile stops at once, whatever numba is doing."""
    signal.signal(signal.SIGINT, signal.SIG_DFL)
    signal.signal(signal.SIGTERM, signal.SIG_DFL)
    scene, types = pickle.loads(sys.stdin.buffer.read())
    scene_code.kernel_of(scene).compile(types)
    return 0


if __name__ == "__main__":
    sys.exit(_child_main())
