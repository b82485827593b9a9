"""Coordinates and provenance of result files (CF-1.8; the layout: ``study.assemble``), and reading them back.

Global attributes: ``Conventions``, ``title``, ``study``, ``references`` (the paper),
``source`` (rimroll version and method), every Params value as ``param_<name>`` plus
``param_rho`` and every study setting as ``setting_<name>`` (except swept ones: those are axes,
named in ``swept``), ``rimroll_version``, ``git_revision`` (when known), ``created`` (UTC,
ISO 8601) and ``history`` (the command line).
"""

from __future__ import annotations

import datetime as _dt
import functools
import importlib
import importlib.metadata
import pathlib
import subprocess

import numpy as np
import xarray as xr

from rimroll import solver
from rimroll.solver.physics.params import TERM_KEYS
from rimroll.study.registry import PHYSICAL_KEYS, Axis, Study

HERE = pathlib.Path(__file__).resolve().parent
CONVENTIONS = "CF-1.8"  # what both CF checkers (compliance-checker, cfchecker) verify; see study.assemble


@functools.lru_cache(maxsize=1)
def rimroll_version() -> str:
    """Version of the rimroll code that runs: what setuptools-scm wrote into this build
    (``rimroll/_version.py``: from git, a tag or ``0.1.devN+g<commit>``), else the installed
    distribution's; 'unknown' if neither."""
    build = _build_record()
    if build.get("version"):
        return str(build["version"])
    try:
        return importlib.metadata.version("rimroll")
    except importlib.metadata.PackageNotFoundError:
        return "unknown"


def _build_record() -> dict:
    """``version``, ``commit`` (git's abbreviated hash, 'g' first) and ``dirty`` of this build, as
    setuptools-scm wrote them into ``rimroll/_version.py`` (pyproject.toml ``[tool.setuptools_scm]``);
    empty when it is absent (a tree never built)."""
    try:
        _version = importlib.import_module("rimroll._version")
    except ImportError:
        return {}
    return {k: getattr(_version, k, None) for k in ("version", "commit", "dirty")}


def _git(*args: str) -> str | None:
    try:
        return subprocess.run(["git", *args], cwd=HERE, capture_output=True, text=True, timeout=10,
                              check=True).stdout.strip()
    except (OSError, subprocess.SubprocessError):
        return None


@functools.lru_cache(maxsize=1)
def git_revision() -> str | None:
    """Commit hash (+'-dirty') of the code that runs, or None; never raises.

    A source checkout (or editable install): the checkout's HEAD now, if this package is its own
    ``study/`` (not, say, a copy in a virtual environment that happens to sit inside a checkout).
    An installed build: the commit its source tree had when it was built (git's abbreviated hash,
    recorded by setuptools-scm in ``rimroll/_version.py``), with '-dirty' when tracked files differed.
    """
    top = _git("rev-parse", "--show-toplevel")
    if top and pathlib.Path(top).resolve() == HERE.parent:
        rev = _git("rev-parse", "HEAD")
        dirty = _git("status", "--porcelain", "--untracked-files=no")
        return f"{rev}-dirty" if rev and dirty else (rev or None)
    build = _build_record()
    commit = str(build.get("commit") or "")
    if not commit:
        return None
    commit = commit[1:] if commit.startswith("g") else commit
    return f"{commit}-dirty" if build.get("dirty") else commit


def _attr_value(value):
    """A netCDF-storable attribute value (bools become 0/1 ints, None an empty string)."""
    if isinstance(value, bool):
        return int(value)
    if value is None:
        return ""
    return value


def _axis_attrs(a: Axis) -> dict:
    """CF attributes of an axis' coordinate: units (none for string labels), long_name and comment."""
    attrs = {"units": a.units, "long_name": a.long_name} if a.units else {"long_name": a.long_name}
    return {**attrs, "comment": a.comment} if a.comment else attrs


def coords_of(axes: list[Axis]) -> dict:
    """xarray coordinates of the axes (each with units and long_name), auxiliary ones included."""
    coords = {a.name: (a.name, a.values, _axis_attrs(a)) for a in axes}
    for a in axes:
        for aux_name, (values, units, long_name) in a.aux.items():
            coords[aux_name] = (a.name, np.asarray(values), {"units": units, "long_name": long_name})
    return coords


def scalar_coords(study: Study, settings: dict, swept: tuple = (), taken=()) -> dict:
    """The run's numeric scalar settings and physical parameters as scalar coordinates
    ``{name: ((), value, {units, long_name})}`` (units and meaning from the setting table), so that
    files of runs that differ in one setting combine along it. Left out: swept settings (axes), the
    physical parameters the study ignores (a scene sets its own), labels and switches (``method``,
    ``backend``: attributes only) and names already ``taken`` by an axis, coordinate or variable."""
    from rimroll.study.setting_table import lookup

    varying = set(swept) | ({"r"} if "rho_over_R" in swept else set())
    out = {}
    for name, value in settings.items():
        if name in varying or name in taken or name in study.ignores or value is None or isinstance(value, bool):
            continue
        if name in PHYSICAL_KEYS or name in study.settings:
            if isinstance(value, (int, float, np.integer, np.floating)):
                entry = lookup(name)
                attrs = {"units": entry.units or "1", "long_name": entry.doc or name}
                out[name] = ((), _number(value), attrs)
    return out


def _number(value) -> np.ndarray:
    """A 0-d array of a setting: int32 for an integer that fits (CF-1.8 has no 64-bit integers), else float64."""
    if isinstance(value, (int, np.integer)) and abs(int(value)) < 2**31:
        return np.asarray(value, dtype=np.int32)
    return np.asarray(value, dtype=np.float64)


def global_attrs(study: Study, params: solver.Params, settings: dict, command: str,
                 swept: tuple = (), device: str | None = None) -> dict:
    """Provenance of one run. ``swept``: names of the settings swept as outer axes; they get no
    ``param_``/``setting_`` attribute (nor ``param_r``, ``param_rho`` when ``rho_over_R`` is
    swept): their coordinates hold their values. ``device``: what the CUDA backend ran on (the
    workers' devices), recorded in ``source``."""
    now = _dt.datetime.now(_dt.timezone.utc).replace(microsecond=0).isoformat()
    version = rimroll_version()
    attrs = {"Conventions": CONVENTIONS, "title": study.title, "study": study.name,
             "references": REFERENCES, "source": _source(study, settings, version, device)}
    varying = set(swept) | ({"r", "rho"} if "rho_over_R" in swept else set())  # one value per point of an axis
    for name, value in params.as_dict().items():
        if name not in varying:
            attrs[f"param_{name}"] = float(value)
    if "rho" not in varying:
        attrs["param_rho"] = float(params.rho)
    for name, value in settings.items():
        if (name not in PHYSICAL_KEYS or name in study.settings) and value is not None and name not in varying:
            attrs[f"setting_{name}"] = _attr_value(value)
    if swept:
        attrs["swept"] = " ".join(swept)
    attrs.update(provenance(command, now, version))
    return attrs


def provenance(command: str, now: str, version: str | None = None) -> dict:
    """rimroll_version, git_revision (when known), created and history attributes of a file."""
    version = version or rimroll_version()
    rev = git_revision()
    out = {"rimroll_version": version}
    if rev:
        out["git_revision"] = rev
    out["created"] = now
    out["history"] = f"{now} {command} - rimroll {version}" + (f" (git {rev})" if rev else "")
    return out


REFERENCES = ("M. Antali, V. Havas, S. J. Hogan, G. Stepan: Nonlinear dynamics of a basketball rolling "
              "around the rim (the paper rimroll reproduces; equation numbers in attributes are its)")


def _source(study: Study, settings: dict, version: str, device: str | None = None) -> str:
    """CF ``source``: the software and the method that made the file (and the backend it ran on)."""
    text = f"rimroll {version}, study {study.name}"
    if "method" in settings and "rtol" in settings:
        method = settings["method"]
        text += (f": solver.simulate, compiled event-driven integrator {'dp5' if method == 'auto' else method} at "
                 f"rtol {settings['rtol']:g}, atol {settings.get('atol', float('nan')):g}")
        if method == "auto":
            text += ("; the conservative rolling-only scene: the exact reduced solver (Sect. 4.4, no integration; "
                     "method auto)")
    elif "rtol" in settings:
        text += f": rtol {settings['rtol']:g}"
    if "backend" in settings:
        backend = settings["backend"]
        where = device if backend == "cuda" and device else ("the workers' GPUs" if backend == "cuda" else None)
        text += f"; backend {backend}" + (f" on {where}" if where else "")
    return text


def params_of(ds: xr.Dataset) -> solver.Params:
    """The ``solver.Params`` of a results file (``param_*`` attributes).

    A swept parameter has no attribute (it varies along its axis): select one point first,
    e.g. ``params_of(ds.sel(mu=1.0))``, and its scalar coordinate is used.
    """
    swept = str(ds.attrs.get("swept", "")).split()
    by_rho = "rho_over_R" in swept  # r follows from rho/R (not recorded)
    # the term parameters came after the first files: a file without them ran with the terms off (defaults)
    values = {k: float(setting_of(ds, k)) for k in PHYSICAL_KEYS
              if not (by_rho and k == "r") and (k not in TERM_KEYS or _recorded(ds, k))}
    if by_rho:
        return solver.Params.from_rho_over_R(float(setting_of(ds, "rho_over_R")), **values)
    return solver.Params(**values)


def _recorded(ds: xr.Dataset, name: str) -> bool:
    return name in ds.coords or name in ds.dims or f"setting_{name}" in ds.attrs or f"param_{name}" in ds.attrs


def setting_of(ds: xr.Dataset, name: str):
    """A recorded setting of a results file: its scalar coordinate (a file's own scalar setting, or
    one point of a swept one selected, ``ds.sel(mu=1.0)``), else the attribute ``setting_<name>`` or
    ``param_<name>``. A setting that varies along a dimension of ``ds`` (swept, or the axis of files
    combined with ``xr.open_mfdataset``) is a ValueError until one point is selected."""
    if name in ds.coords and ds[name].ndim == 0:
        return ds[name].item()
    if name in ds.dims:
        raise ValueError(f"{name!r} is swept in this file ({ds.sizes[name]} values along its axis); select one "
                         f"point first, e.g. ds.sel({name}={ds[name].values[0]!r})")
    if f"setting_{name}" in ds.attrs:
        return ds.attrs[f"setting_{name}"]
    if f"param_{name}" in ds.attrs:
        return ds.attrs[f"param_{name}"]
    if name in ds.coords:
        raise ValueError(f"{name!r} is swept in this file ({ds[name].size} values along its axis); select one "
                         f"point first, e.g. ds.sel({name}={ds[name].values[0]!r})")
    raise KeyError(f"no setting or parameter {name!r} recorded in this file")

