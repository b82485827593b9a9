"""A one-line progress display: ``study: NAME chunks k/N (r resumed) 12.3 s, ETA 40 s``.

In a terminal the line is redrawn in place on stderr; in a Jupyter notebook (an IPython kernel)
it is one output of the cell, a progress bar with the same text, updated in place
(``IPython.display`` with a ``display_id``; no widget library needed). Silent for the first
``minimum`` seconds so that quick runs show nothing. The ETA is the mean time per chunk computed
in this run times the chunks left.
"""

from __future__ import annotations

import html
import sys
import time


def in_notebook() -> bool:
    """Whether this process is a Jupyter kernel (IPython's ZMQ shell), without importing IPython."""
    ipython = sys.modules.get("IPython")
    if ipython is None:
        return False
    try:
        shell = ipython.get_ipython()
    except Exception:  # noqa: BLE001  an IPython too old or half imported: not a notebook we can draw in
        return False
    return type(shell).__name__ == "ZMQInteractiveShell"


def wanted(progress: bool | None) -> bool:
    """``progress``, or when None: shown in a notebook and when stderr is a terminal."""
    if progress is not None:
        return bool(progress)
    return in_notebook() or sys.stderr.isatty()


class _Terminal:
    """The line redrawn in place on a text stream."""

    def __init__(self, stream):
        self.stream = stream

    def show(self, text: str, done: int, total: int) -> None:
        self.stream.write("\r" + text + "\x1b[K")
        self.stream.flush()

    def close(self) -> None:
        self.stream.write("\n")
        self.stream.flush()


class _Notebook:
    """One cell output, updated in place: an HTML progress bar and the line (plain text elsewhere)."""

    def __init__(self, display=None):
        if display is None:
            from IPython.display import display
        self.display = display
        self.handle = None

    def show(self, text: str, done: int, total: int) -> None:
        bundle = {"text/plain": text,
                  "text/html": f'<progress value="{done}" max="{total}" style="width: 24em"></progress> '
                               f"<code>{html.escape(text)}</code>"}
        if self.handle is None:
            self.handle = self.display(bundle, raw=True, display_id=True)
        else:
            self.handle.update(bundle, raw=True)

    def close(self) -> None:
        pass


class ProgressLine:
    """Count finished chunks and redraw one line (at most every 0.2 s): on ``stream`` (default
    stderr), or in a notebook's cell output when this process is a notebook's kernel and no
    ``stream`` is given (``display``: IPython's, replaceable for tests)."""

    def __init__(self, total: int, label: str, resumed: int = 0, enabled: bool = True,
                 minimum: float = 2.0, stream=None, display=None):
        self.total, self.label, self.resumed = total, label, resumed
        self.enabled, self.minimum = enabled, minimum
        if display is not None or (stream is None and in_notebook()):
            self.sink = _Notebook(display)
        else:
            self.sink = _Terminal(stream or sys.stderr)
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
        self.sink.show(self.line(now), self.done, self.total)

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
            self.sink.close()
