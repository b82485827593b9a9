"""The ``study`` console script, ahead of its imports.

Importing the command (numba, xarray, dask, the kernels' cache) takes a second or more; Ctrl-C in
that second is ``study: interrupted`` and exit 130, as it is later (``rimroll.study.cli``), never
a ``KeyboardInterrupt`` traceback; after the command, Ctrl-C during the interpreter's shutdown is
ignored. This module imports nothing heavy itself.
"""

from __future__ import annotations

import os
import sys

EXIT_INTERRUPTED = 130
EXIT_TERMINATED = 143  # 128 + SIGTERM


def main() -> int:
    """Entry point of the ``study`` console script: :func:`rimroll.study.cli.main`."""
    sys.unraisablehook = _interrupt_in_a_callback_goes_on
    _terminated_while_starting.install()
    try:
        from rimroll.study.cli import main as command

        return command()
    except KeyboardInterrupt:
        # Ctrl-C can land while a compiled extension (numba, llvmlite, netCDF4) is half imported, and
        # the interpreter's shutdown then aborts (a fatal error on the GIL, exit -6): nothing has been
        # computed yet that is not already on disk, so leave at once, skipping that shutdown
        print("study: interrupted", file=sys.stderr)
        sys.stdout.flush()
        sys.stderr.flush()
        os._exit(EXIT_INTERRUPTED)
    finally:
        _quiet_exit()


class _TerminatedWhileStarting:
    """SIGTERM while the command imports (before ``rimroll.study.stopping`` takes SIGTERM over): nothing
    is computed yet, so one line and exit 143 at once, as Ctrl-C's 130 above (the default action would
    kill the process with no word, status -15). ``replaceable``: the command's own handler replaces it."""

    replaceable = True

    def __call__(self, signum, frame) -> None:
        print("study: terminated (SIGTERM)", file=sys.stderr)
        sys.stderr.flush()
        os._exit(EXIT_TERMINATED)

    def install(self) -> None:
        import signal

        try:
            if signal.getsignal(signal.SIGTERM) == signal.SIG_DFL:
                signal.signal(signal.SIGTERM, self)
        except ValueError:  # not the main thread
            pass


_terminated_while_starting = _TerminatedWhileStarting()


def _interrupt_in_a_callback_goes_on(unraisable) -> None:
    """``sys.unraisablehook`` of the command: a Ctrl-C that lands while Python runs a callback (a weak
    reference's, a finaliser's: objects freed as a command returns) cannot interrupt anything, and
    Python would print it as "Exception ignored ... Traceback ... KeyboardInterrupt"; it is dropped
    (the command goes on to its end, whose exit status and one line stand). Anything else is
    reported as Python does."""
    if isinstance(unraisable.exc_value, KeyboardInterrupt):
        if type(unraisable.exc_value).__name__ == "Terminated":  # a SIGTERM: the command must still stop
            from rimroll.study import stopping

            stopping.redeliver()
        return
    sys.__unraisablehook__(unraisable)


def _quiet_exit() -> None:
    """The command has said what it did: Ctrl-C while the interpreter shuts down (dask's threads,
    atexit handlers) is ignored, so that the exit status and stderr stay the command's own. And the
    garbage collector leaves the objects alive at this point alone (``gc.freeze``): the shutdown's
    collections otherwise walk numba's graph of compiled functions, 0.4 of the 2.7 s of a warm
    ``study run fig11 --quick``. Every file the command wrote is closed by now; the operating system
    takes the memory back."""
    import gc
    import signal

    try:
        signal.signal(signal.SIGINT, signal.SIG_IGN)
        signal.signal(signal.SIGTERM, signal.SIG_IGN)  # the exit status stays the command's (143 after a SIGTERM)
    except ValueError:  # not the main thread
        pass
    gc.freeze()
