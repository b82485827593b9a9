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


def main() -> int:
    """Entry point of the ``study`` console script: :func:`rimroll.study.cli.main`."""
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


def _quiet_exit() -> None:
    """The command has said what it did: Ctrl-C while the interpreter shuts down (dask's threads,
    atexit handlers) is ignored, so that the exit status and stderr stay the command's own."""
    import signal

    try:
        signal.signal(signal.SIGINT, signal.SIG_IGN)
    except ValueError:  # not the main thread
        pass
