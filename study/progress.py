"""A one-line progress display: ``study: NAME chunks k/N (r resumed) 12.3 s, ETA 40 s`` on stderr.

Silent for the first ``minimum`` seconds so that quick runs print nothing. The ETA is the
mean time per chunk computed in this run times the chunks left.
"""

from __future__ import annotations

import sys
import time


class ProgressLine:
    """Count finished chunks and redraw one stderr line (at most every 0.2 s)."""

    def __init__(self, total: int, label: str, resumed: int = 0, enabled: bool = True,
                 minimum: float = 2.0, stream=None):
        self.total, self.label, self.resumed = total, label, resumed
        self.enabled, self.minimum = enabled, minimum
        self.stream = stream or sys.stderr
        self.done = resumed
        self.t0 = time.monotonic()
        self.last = -1.0
        self.shown = False

    def advance(self, n: int = 1) -> None:
        self.done += n
        now = time.monotonic()
        if not self.enabled or now - self.t0 < self.minimum:
            return
        if self.done < self.total and now - self.last < 0.2:
            return
        self.last = now
        self.shown = True
        self.stream.write("\r" + self.line(now) + "\x1b[K")
        self.stream.flush()

    def line(self, now: float | None = None) -> str:
        elapsed = (time.monotonic() if now is None else now) - self.t0
        new = self.done - self.resumed
        text = f"study: {self.label} chunks {self.done}/{self.total}"
        if self.resumed:
            text += f" ({self.resumed} resumed)"
        text += f" {elapsed:.1f} s"
        if 0 < new and self.done < self.total:
            text += f", ETA {elapsed / new * (self.total - self.done):.0f} s"
        return text

    def close(self) -> None:
        if self.shown:
            self.stream.write("\n")
            self.stream.flush()
