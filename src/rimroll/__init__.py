"""rimroll: nonlinear dynamics of a basketball rolling around the rim.

In a notebook or a script::

    import rimroll

    ds = rimroll.run("fig11", quick=True)          # an xarray.Dataset, with a progress bar
    ds = rimroll.run("outcome-cube", quick=True, mu=[0.25, 0.5, 1], out="runs")   # a swept cube, in runs/
    ds = rimroll.open("runs/outcome-cube.nc")       # a result file, opened lazily
    rimroll.studies()                               # {name: title} of every named study

Three subpackages, each importable on its own (``import rimroll`` loads none of them, nor xarray,
dask or numba):

* :mod:`rimroll.solver`: the physics and its integration, numpy arrays in and out;
* :mod:`rimroll.study`: named studies as labelled xarray/netCDF results, dask fan-out, plots and
  the ``study`` command (``python -m rimroll.study``); :func:`run`, :func:`open` and
  :func:`studies` are :mod:`rimroll.study.api`;
* :mod:`rimroll.workflows`: the named studies themselves (every figure of the paper, parameter cubes).

Notices go through :mod:`logging` (logger ``"rimroll"``, INFO), results with failed lanes raise a
:class:`LaneStatusWarning` (:mod:`warnings`). The layout and what each part may import:
docs/architecture.md.
"""

from __future__ import annotations

import importlib
from typing import TYPE_CHECKING

from rimroll._messages import LaneStatusWarning, RimrollWarning, install

install()  # notices at INFO on stderr until the application configures logging (rimroll._messages)

if TYPE_CHECKING:  # for type checkers and IDEs; at run time they load on first use
    from rimroll.study.api import open, run, studies
    from rimroll.study.registry import UserError

_SUBPACKAGES = ("solver", "study", "workflows")
_API = ("run", "open", "studies")

__all__ = ["__version__", "LaneStatusWarning", "RimrollWarning", "UserError", "run", "open", "studies", "solver",
           "study", "workflows"]


def __getattr__(name: str):
    """``rimroll.solver``, ``rimroll.run`` and friends, imported on first use (``import rimroll`` stays cheap:
    the ``study`` command's Ctrl-C handling starts after it, rimroll._command)."""
    if name == "__version__":  # importlib.metadata is three quarters of this module's import time
        return _installed_version()
    if name in _SUBPACKAGES:
        return importlib.import_module(f"rimroll.{name}")
    if name in _API:
        return getattr(importlib.import_module("rimroll.study.api"), name)
    if name == "UserError":  # what run and open raise for bad input: one line, fixable by the user
        return importlib.import_module("rimroll.study.registry").UserError
    raise AttributeError(f"module 'rimroll' has no attribute {name!r}")


def _installed_version() -> str:
    """The installed distribution's version ("0+unknown" for a source tree that was never installed)."""
    from importlib.metadata import PackageNotFoundError, version

    try:
        return version("rimroll")
    except PackageNotFoundError:
        return "0+unknown"


def __dir__() -> list[str]:
    """The public names (``__all__``), not the helpers this module imports (``version``, ``install``,
    ``importlib``, ...), which tab completion would offer as rimroll's own."""
    return sorted(__all__)
