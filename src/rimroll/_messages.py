"""How rimroll talks: ``logging`` for notices, ``warnings`` for results that need a look.

* Notices (a kernel's first compile, the plan of a long run, the time left, the dashboard of a
  cluster) are ``logging`` records at INFO under the logger ``"rimroll"`` (``rimroll.solver...``,
  ``rimroll.study...``). ``logging.getLogger("rimroll").setLevel(logging.WARNING)`` silences them.
* A result with lanes whose integration did not finish ok is a ``LaneStatusWarning``
  (a ``RimrollWarning``): ``warnings.filterwarnings("ignore", category=rimroll.LaneStatusWarning)``
  silences it, ``"error"`` turns it into an exception.

Until the application configures logging (a handler on the root logger), rimroll's records go to
stderr as one line each (``rimroll: ...`` from the solver, ``study: ...`` from the study layer),
which is what a notebook or a terminal shows. Once the root logger has a handler, rimroll's records
go there only (they propagate as usual). The ``study`` command always writes them to stderr.
Cheap to import: ``import rimroll`` loads this module.
"""

from __future__ import annotations

import contextlib
import logging
import sys

LOGGER = "rimroll"


class RimrollWarning(UserWarning):
    """Base class of rimroll's warnings."""


class LaneStatusWarning(RimrollWarning):
    """Some lanes of a result did not finish their integration ok (see the result's ``status`` variable)."""


class _Prefix(logging.Formatter):
    """``study: ...`` for the study layer's records, ``rimroll: ...`` for the others."""

    def format(self, record: logging.LogRecord) -> str:
        prefix = "study" if record.name.startswith(f"{LOGGER}.study") else "rimroll"
        return f"{prefix}: {record.getMessage()}"


class DefaultHandler(logging.Handler):
    """rimroll's records on the current ``sys.stderr`` while the application has configured no
    logging of its own (``always``: whatever it has configured: the ``study`` command)."""

    always = False

    def __init__(self) -> None:
        super().__init__(logging.NOTSET)
        self.setFormatter(_Prefix())

    def emit(self, record: logging.LogRecord) -> None:
        if not self.always and logging.getLogger().handlers:
            return  # the application's handlers receive the record through propagation
        try:
            stream = sys.stderr
            stream.write(self.format(record) + "\n")
            stream.flush()
        except Exception:  # noqa: BLE001  logging's own policy: report, never raise
            self.handleError(record)


def install() -> DefaultHandler:
    """Give the ``rimroll`` logger its default handler (once) and level INFO unless one was set."""
    logger = logging.getLogger(LOGGER)
    for h in logger.handlers:
        if isinstance(h, DefaultHandler):
            return h
    handler = DefaultHandler()
    logger.addHandler(handler)
    if logger.level == logging.NOTSET:
        logger.setLevel(logging.INFO)
    return handler


@contextlib.contextmanager
def command_line():
    """While the ``study`` command runs, rimroll's notices go to stderr whatever else is configured."""
    handler = install()
    before, handler.always = handler.always, True
    try:
        yield
    finally:
        handler.always = before
