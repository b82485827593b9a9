"""SIGTERM to the ``study`` command: one stop, one line, exit 143, every time.

SIGTERM (``timeout``, a batch system ending a job) stops the command as Ctrl-C does: the handler
raises :class:`registry.Terminated` (a KeyboardInterrupt) in the main thread, the run's guard says
what was saved, and the command exits 143. Three things made that fail now and then:

- a second SIGTERM while the first one's cleanup runs (the local cluster torn down, the lock
  released) raised again inside that cleanup, or killed the process (exit -15) once the command
  had put the default action back. Only the first SIGTERM of a command stops it; later ones are
  ignored (the cleanup is bounded: every wait of a run has a timeout), also after the command
  returned (:func:`restore`);
- a SIGTERM inside an import (the studies' modules import numba, whose compiled extensions print
  the interrupt as a traceback and turn it into ImportError) is delivered again 50 ms later,
  until the main thread is outside every import (:func:`_importing`);
- dask's ``utils.sync`` interrupted before its coroutine started schedules a callback that fails
  with ``NameError: cannot access free variable 'future'``, logged by the event loop's thread
  (``tornado.application``) with a traceback. From the first SIGTERM the loggers of the event loop
  and of dask (:data:`TEARDOWN_LOGGERS`) are silenced for the rest of the command: it is ending,
  and its one line says how.

A SIGTERM that lands in a callback Python cannot interrupt (a finaliser: the command's
``sys.unraisablehook`` drops it) is re-armed and delivered again (:func:`redeliver`).
"""

from __future__ import annotations

import logging
import os
import signal
import threading

from rimroll.study import registry

TEARDOWN_LOGGERS = ("tornado.application", "asyncio", "distributed")
"""Loggers of the event loop and of dask, silenced once a command is stopping (their tracebacks
come from callbacks of futures cancelled by the stop, in dask's threads)."""

RETRY_S = 0.05  # [s] a SIGTERM inside an import is delivered again after this long


class _State:
    installed = False  # our handler is the process's SIGTERM handler
    raised = False  # the first SIGTERM of the command has raised Terminated


_state = _State()


def silence(names=TEARDOWN_LOGGERS) -> dict:
    """Set the loggers ``names`` above CRITICAL; returns their levels, for :func:`unsilence`."""
    levels = {name: logging.getLogger(name).level for name in names}
    for name in names:
        logging.getLogger(name).setLevel(logging.CRITICAL + 1)
    return levels


def unsilence(levels: dict) -> None:
    """Give the loggers the levels :func:`silence` returned."""
    for name, level in levels.items():
        logging.getLogger(name).setLevel(level)


def _importing(frame) -> bool:
    """Whether the main thread, at ``frame``, is inside an import (a frame of importlib's bootstrap
    below it)."""
    while frame is not None:
        if frame.f_code.co_filename.startswith("<frozen importlib"):
            return True
        frame = frame.f_back
    return False


def _later() -> None:
    """Deliver SIGTERM to this process again in :data:`RETRY_S` seconds (a daemon timer thread)."""
    timer = threading.Timer(RETRY_S, os.kill, (os.getpid(), signal.SIGTERM))
    timer.daemon = True
    timer.start()


def _terminated(signum, frame) -> None:
    if _state.raised:
        return  # the command is stopping already; its cleanup is bounded
    if _importing(frame):
        _later()
        return
    _state.raised = True
    silence()
    raise registry.Terminated()


def install():
    """Make SIGTERM stop the command (see the module), where SIGTERM has its default action or the
    console script's start-up handler (``rimroll._command``; an application that set its own keeps
    it). Returns the handler to give back to :func:`restore` (None: nothing changed)."""
    _state.raised = False
    try:
        current = signal.getsignal(signal.SIGTERM)
        if current == signal.SIG_DFL or getattr(current, "replaceable", False):  # rimroll._command's
            previous = signal.signal(signal.SIGTERM, _terminated)
            _state.installed = True
            return previous
    except ValueError:  # not the main thread
        pass
    return None


def restore(previous) -> None:
    """The command returns: SIGTERM gets its ``previous`` handler back, unless the command was stopped
    by one, then later ones are ignored (the process is ending with exit 143; a second SIGTERM would
    otherwise kill it with -15)."""
    if previous is None:
        return
    _state.installed = False
    try:
        signal.signal(signal.SIGTERM, signal.SIG_IGN if _state.raised else previous)
    except ValueError:
        pass


def redeliver() -> None:
    """A :class:`registry.Terminated` was dropped where Python cannot raise it (a finaliser): re-arm and
    send SIGTERM again, so that the command still stops."""
    if _state.installed and _state.raised:
        _state.raised = False
        _later()
