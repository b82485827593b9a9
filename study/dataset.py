"""Assemble a study's numpy results into a CF-1.10 ``xarray.Dataset`` with provenance.

Global attributes: ``Conventions``, ``title``, ``study``, every Params value as
``param_<name>`` plus ``param_rho``, every study setting as ``setting_<name>``,
``rimroll_version``, ``git_revision`` (when git can tell), ``created`` (UTC, ISO 8601) and
``history`` (the command line).
"""

from __future__ import annotations

import datetime as _dt
import functools
import importlib.metadata
import pathlib
import subprocess

import numpy as np
import xarray as xr

import solver
from study.registry import PHYSICAL_KEYS, Axis, Study


def rimroll_version() -> str:
    """Installed version of the ``rimroll`` distribution ('unknown' if not installed)."""
    try:
        return importlib.metadata.version("rimroll")
    except importlib.metadata.PackageNotFoundError:
        return "unknown"


@functools.lru_cache(maxsize=1)
def git_revision() -> str | None:
    """Commit hash of the source tree this package runs from (+'-dirty'), or None; never raises."""
    here = pathlib.Path(__file__).resolve().parent
    try:
        rev = subprocess.run(["git", "rev-parse", "HEAD"], cwd=here, capture_output=True, text=True,
                             timeout=5, check=True).stdout.strip()
        dirty = subprocess.run(["git", "status", "--porcelain", "--untracked-files=no"], cwd=here,
                               capture_output=True, text=True, timeout=10).stdout.strip()
    except (OSError, subprocess.SubprocessError):
        return None
    return f"{rev}-dirty" if dirty else (rev or None)


def _attr_value(value):
    """A netCDF-storable attribute value (bools become 0/1 ints, None an empty string)."""
    if isinstance(value, bool):
        return int(value)
    if value is None:
        return ""
    return value


def _axis_attrs(a: Axis) -> dict:
    """CF attributes of an axis' coordinate: units (none for string labels) and long_name."""
    return {"units": a.units, "long_name": a.long_name} if a.units else {"long_name": a.long_name}


def coords_of(axes: list[Axis]) -> dict:
    """xarray coordinates of the axes (each with units and long_name), auxiliary ones included."""
    coords = {a.name: (a.name, a.values, _axis_attrs(a)) for a in axes}
    for a in axes:
        for aux_name, (values, units, long_name) in a.aux.items():
            coords[aux_name] = (a.name, np.asarray(values), {"units": units, "long_name": long_name})
    return coords


def global_attrs(study: Study, params: solver.Params, settings: dict, command: str,
                 swept: tuple = ()) -> dict:
    """Provenance of one run. ``swept``: names of the settings swept as outer axes (their
    ``param_``/``setting_`` attributes hold the first value; the coordinate holds all)."""
    now = _dt.datetime.now(_dt.timezone.utc).replace(microsecond=0).isoformat()
    attrs = {"Conventions": "CF-1.10", "title": study.title, "study": study.name}
    for name, value in params.as_dict().items():
        attrs[f"param_{name}"] = float(value)
    attrs["param_rho"] = float(params.rho)
    for name, value in settings.items():
        if (name not in PHYSICAL_KEYS or name in study.settings) and value is not None:
            attrs[f"setting_{name}"] = _attr_value(value[0] if isinstance(value, tuple) else value)
    if swept:
        attrs["swept"] = " ".join(swept)
    version = rimroll_version()
    attrs["rimroll_version"] = version
    rev = git_revision()
    if rev:
        attrs["git_revision"] = rev
    attrs["created"] = now
    attrs["history"] = f"{now} {command} - rimroll {version}" + (f" (git {rev})" if rev else "")
    return attrs


def build_dataset(study: Study, axes: list[Axis], arrays: dict, params: solver.Params,
                  settings: dict, command: str) -> xr.Dataset:
    """The Dataset of one run: coordinates from ``axes``, variables from ``arrays``."""
    from study.derived import with_derived

    dims = [a.name for a in axes]
    data = {v.name: (dims, arrays[v.name], v.attrs) for v in study.variables}
    ds = xr.Dataset(data, coords=coords_of(axes), attrs=global_attrs(study, params, settings, command))
    return with_derived(study, ds)


def params_of(ds: xr.Dataset) -> solver.Params:
    """The :class:`solver.Params` recorded in a results file's ``param_*`` attributes."""
    return solver.Params(**{k: float(ds.attrs[f"param_{k}"]) for k in PHYSICAL_KEYS})


def setting_of(ds: xr.Dataset, name: str):
    """A recorded setting (``setting_<name>``, else ``param_<name>``) of a results file."""
    if f"setting_{name}" in ds.attrs:
        return ds.attrs[f"setting_{name}"]
    return ds.attrs[f"param_{name}"]

