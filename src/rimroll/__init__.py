"""rimroll: nonlinear dynamics of a basketball rolling around the rim.

Three subpackages, each importable on its own (``import rimroll`` loads none of them):

* :mod:`rimroll.solver`: the physics and its integration, numpy arrays in and out;
* :mod:`rimroll.study`: named studies as labelled xarray/netCDF results, dask fan-out, plots and
  the ``study`` command (``python -m rimroll.study``);
* :mod:`rimroll.workflows`: the named studies themselves (every figure of the paper, parameter cubes).

The layout and what each part may import: docs/architecture.md.
"""

from __future__ import annotations

import importlib
from importlib.metadata import PackageNotFoundError, version

try:
    __version__ = version("rimroll")
except PackageNotFoundError:  # a source tree that was never installed
    __version__ = "0+unknown"

_SUBPACKAGES = ("solver", "study", "workflows")

__all__ = ["__version__", *_SUBPACKAGES]


def __getattr__(name: str):
    """``rimroll.solver`` and friends, imported on first use (``import rimroll`` stays cheap)."""
    if name in _SUBPACKAGES:
        return importlib.import_module(f"rimroll.{name}")
    raise AttributeError(f"module 'rimroll' has no attribute {name!r}")
