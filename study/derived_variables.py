"""Derived variables: what a study computes once from the whole assembled grid (``Study.derive``).

Chunks are computed independently; some results need neighbours across chunks (e.g. the
boundary types of an outcome section, ``solver.analysis.boundaries``). A study declares
``derive(ds) -> {name: (dims, values, attrs)}``; it is called once on the assembled Dataset
(variables read lazily from the file) before the final file is moved into place, and its
variables are added to that file. Deterministic and pure, like ``compute``: re-running the
assembly (resume) gives the same file.
"""

from __future__ import annotations

import numpy as np
import xarray as xr

from rimroll.study.registry import Study


def derived_variables(study: Study, ds: xr.Dataset) -> dict[str, tuple[tuple, np.ndarray, dict]]:
    """The study's derived variables for ``ds``, checked: ``{name: (dims, values, attrs)}``.

    Each must use dimensions of ``ds`` (values shaped accordingly), carry ``units`` and
    ``long_name``, and not reuse the name of a variable or coordinate of ``ds``. A dimension
    that ``ds`` lacks (e.g. ``eps`` of an f(eps) curve) is allowed when ``derive`` also returns
    its coordinate, a 1-D variable of that name along it; coordinates come first in the
    result. A new dimension without a coordinate (the points or curves of a CF ragged array
    or geometry) takes its size from the first variable along it, and every other must agree.
    The attribute
    ``rimroll_derived = 1`` is added (``study.compare`` does not use derived categorical
    variables to decide which points lie away from boundaries).
    """
    if study.derive is None:
        return {}
    out = {}
    items = {name: (tuple(dims), np.asarray(values), attrs) for name, (dims, values, attrs) in study.derive(ds).items()}
    # a new dimension comes with its coordinate: a 1-D derived variable named like it
    sizes = dict(ds.sizes)
    for name, (dims, values, _) in items.items():
        if dims == (name,) and name not in ds.sizes:
            sizes[name] = values.shape[0]
    for dims, values, _ in items.values():  # a dimension without a coordinate: its first variable's size
        for d, n in zip(dims, values.shape):
            sizes.setdefault(d, n)
    items = dict(sorted(items.items(), key=lambda kv: kv[1][0] != (kv[0],)))  # coordinates first
    for name, (dims, values, attrs) in items.items():
        if name in ds.variables:
            raise ValueError(f"study {study.name!r}: derived variable {name!r} already exists in the dataset")
        if any(d not in sizes for d in dims) or values.shape != tuple(sizes[d] for d in dims):
            raise ValueError(f"study {study.name!r}: derived variable {name!r} has dims {dims} and shape "
                             f"{values.shape}, not matching the dataset's sizes {sizes} (a new dimension "
                             "needs a 1-D derived coordinate of the same name)")
        if not attrs.get("units") or not attrs.get("long_name"):
            raise ValueError(f"study {study.name!r}: derived variable {name!r} needs units and long_name")
        out[name] = (dims, values, {**attrs, "rimroll_derived": 1})
    return out
