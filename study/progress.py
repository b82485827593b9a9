"""A one-line progress display for dask runs: ``study: NAME chunks k/N`` on stderr.

Silent for the first ``minimum`` seconds so that quick runs print nothing.
"""

from __future__ import annotations

import sys
import time

from dask.callbacks import Callback


class ChunkProgress(Callback):
    """Count finished chunk tasks (keys named ``chunk-*``) and redraw one stderr line."""

    def __init__(self, total: int, label: str, minimum: float = 2.0, stream=None):
        super().__init__()
        self.total, self.label, self.minimum = total, label, minimum
        self.stream = stream or sys.stderr
        self.done = 0
        self.shown = False

    def _start(self, dsk):
        self.t0 = time.monotonic()
        self.done = 0

    def _posttask(self, key, result, dsk, state, worker_id):
        if isinstance(key, str) and key.startswith("chunk-"):
            self.done += 1
        if time.monotonic() - self.t0 >= self.minimum:
            self.shown = True
            self.stream.write(f"\rstudy: {self.label} chunks {self.done}/{self.total} "
                              f"({time.monotonic() - self.t0:.1f} s)")
            self.stream.flush()

    def _finish(self, dsk, state, errored):
        if self.shown:
            self.stream.write("\n")
            self.stream.flush()
