"""Stored reference slices: small, precise results of every map and outcome study.

The slices ship inside the package (``study/reference_slices/``, package data found with
``importlib.resources``), so ``study verify`` works after ``pip install .``. Each study has two
(:data:`GRIDS`), made by ``study reference --build`` with the study's own plan and fan-out:

* ``<study>.nc``, the **default** slice: a coarse sub-grid of the study's default grid (every
  axis: ``points`` values picked from the default axis, ends included: a 36 x 24 sub-grid of
  each outcome section in all four scenes, 121 x 80 of the steady maps, 40 x 30 of fig9), so a
  full-resolution run shares every reference point;
* ``quick/<study>.nc``, the **quick** slice: the whole ``--quick`` grid, so that a first
  ``study run NAME --quick`` can be verified on every one of its points (a quick grid is not a
  sub-grid of the default one: the two share only their corners).

Both at the study's settings, the outcome sections at rtol = 1e-12 with DOP853. What a study's
slices are is a field of its record, ``Study.reference`` (a
:class:`~rimroll.study.registry.ReferenceSpec`: the sub-grid's points per axis, the precision
settings, the method text); :func:`specs` lists the studies that have one.
``study verify FILE`` compares a file with the slice of its study that shares the most points
with it (:func:`candidates`); the regression tests (``tests/study/test_reference_slices.py``)
recompute each slice at the study's default precision (:func:`recompute`) and compare with
``study.compare``. ``study reference --build`` writes ``--out DIR``; without ``--out`` only in a
source checkout (never into an installed package).

Every file records how it was made in global attributes: ``reference_command``,
``reference_settings`` (the ``--quick``/``--set`` of the run), ``reference_rtol``,
``reference_atol``, ``reference_method`` and the usual provenance (``rimroll_version``,
``git_revision``, ``created``, ``history``).
"""

from __future__ import annotations

import importlib.resources
import os
import pathlib
import shlex
import tempfile

import numpy as np
import xarray as xr

from rimroll.study import cli_text, execute, fanout, registry
from rimroll.study.parts import PartStore
from rimroll.study.plan import Plan, make_plan

ENV_DIR = "RIMROLL_REFERENCE_DIR"
PACKAGE_DIR = "reference_slices"  # package data of ``rimroll.study``
GRIDS = ("default", "quick")
"""The two slices of a study: a sub-grid of its default grid, and its whole ``--quick`` grid
(in the subdirectory ``quick/``)."""


def specs() -> dict[str, registry.ReferenceSpec]:
    """Name -> :class:`~rimroll.study.registry.ReferenceSpec` of every registered study that has
    reference slices (``Study.reference``), in the natural order of the names."""
    found = {name: registry.get(name).reference for name in registry.natural_order(registry.names())}
    return {name: spec for name, spec in found.items() if spec is not None}


def spec_of(name: str) -> registry.ReferenceSpec:
    """The reference spec of study ``name``; a :class:`registry.UserError` if it has none."""
    spec = registry.get(name).reference
    if spec is None:
        raise registry.UserError(f"no reference slice for {name}; known: {', '.join(specs())}")
    return spec


def sub_grid(name: str) -> dict:
    """``{axis: (v1, v2, ...)}``: the default slice's sub-grid of study ``name`` (exact values of the
    default axes: ``points`` values of each, ends included)."""
    full = {a.name: a.values for a in make_plan(registry.get(name)).grid}
    out = {}
    for axis, n in spec_of(name).points.items():
        idx = np.unique(np.round(np.linspace(0, full[axis].size - 1, n)).astype(int))
        out[axis] = tuple(float(v) for v in full[axis][idx])
    return out


def slice_plan(name: str, grid: str = "default", precise: bool = True) -> Plan:
    """The plan of the ``grid`` slice of study ``name`` (``precise``: the reference, at the spec's
    precision settings; else the study's own precision on the same grid)."""
    _check_grid(grid)
    extra = spec_of(name).precise if precise else {}
    if grid == "quick":
        return make_plan(registry.get(name), True, extra)
    return make_plan(registry.get(name), False, {**sub_grid(name), **spec_of(name).sets, **extra})


def packaged_dir() -> pathlib.Path:
    """The slices shipped with the package (``study/reference_slices``, package data)."""
    return pathlib.Path(str(importlib.resources.files("rimroll.study").joinpath(PACKAGE_DIR)))


def reference_dir() -> pathlib.Path:
    """Where the stored slices are read: ``$RIMROLL_REFERENCE_DIR``, else the packaged slices."""
    return pathlib.Path(os.environ.get(ENV_DIR) or packaged_dir())


def checkout_dir() -> pathlib.Path | None:
    """``study/reference_slices`` of a source checkout (a git work tree with pyproject.toml), or None
    when ``study`` runs from an installed package, which is never written."""
    package = pathlib.Path(__file__).resolve().parent
    root = package.parent
    if (root / "pyproject.toml").is_file() and (root / ".git").exists() and "-packages" not in str(package):
        return package / PACKAGE_DIR
    return None


def default_build_dir() -> pathlib.Path:
    """Where ``study reference --build`` writes without ``--out``: ``$RIMROLL_REFERENCE_DIR``, else
    the checkout's slices, else a :class:`registry.UserError` asking for ``--out``."""
    if os.environ.get(ENV_DIR):
        return pathlib.Path(os.environ[ENV_DIR])
    target = checkout_dir()
    if target is None:
        raise registry.UserError(f"study reference --build needs --out DIR here: rimroll is installed at "
                                 f"{pathlib.Path(__file__).resolve().parent.parent} and the installed package is "
                                 f"never written (read a built directory with study verify --reference DIR)")
    return target


def reference_path(study: str, directory=None, grid: str = "default") -> pathlib.Path:
    """Path of the ``grid`` slice of ``study`` in ``directory`` (default :func:`reference_dir`)."""
    _check_grid(grid)
    root = pathlib.Path(directory or reference_dir())
    return root / f"{study}.nc" if grid == "default" else root / grid / f"{study}.nc"


def candidates(study: str, directory=None) -> list[pathlib.Path]:
    """The stored slices of ``study`` in ``directory``, default grid first (``study verify`` takes
    the one sharing the most points with the file)."""
    return [p for p in (reference_path(study, directory, g) for g in GRIDS) if p.is_file()]


def _check_grid(grid: str) -> None:
    if grid not in GRIDS:
        raise registry.UserError(f"no reference grid {grid!r}; known: {', '.join(GRIDS)}")


def recompute(name: str, precise: bool = False, workers: int = 2, grid: str = "default") -> xr.Dataset:
    """The ``grid`` slice of ``name`` computed in memory through the study's plan and fan-out
    (``study.execute.compute``), derived variables included; ``precise``: at the reference's
    precision, else at the study's own."""
    plan = slice_plan(name, grid, precise)
    return execute.compute(plan, f"study.reference.recompute({name!r}, precise={precise}, grid={grid!r})", workers)


def _provenance(spec: registry.ReferenceSpec, grid: str, plan: Plan, command: str) -> dict:
    s = plan.settings
    sets = shlex.join([*(f"--set={x}" for x in cli_text.words(spec.precise))])
    if grid == "quick":
        how = " ".join(filter(None, ["--quick", sets])) + " on the whole --quick grid"
    else:
        held = shlex.join(f"--set={x}" for x in cli_text.words(spec.sets))
        how = " ".join(filter(None, [sets, held])) + " on the sub-grid " + \
            ", ".join(f"{k}: {n} of the default values (ends included)" for k, n in spec.points.items())
    return {
        "reference_command": command,
        "reference_settings": how,
        "reference_rtol": str(s.get("rtol", "n/a")),
        "reference_atol": str(s.get("atol", "n/a")),
        "reference_method": str(s.get("method", spec.method)),
        "reference_precision": "the reference's own (rtol, method above)" if spec.precise else
                               "the study's own settings: a regression reference (a run at the defaults "
                               "reproduces it)",
        "reference_purpose": "stored reference slice of rimroll: regression tests and `study verify`",
    }


def build(out=None, names=None, workers: int | None = None, command: str = "study reference --build",
          progress: bool = False, grids=GRIDS) -> list[pathlib.Path]:
    """Compute the slices ``names`` (default: all) on ``grids`` (default: both) into ``out``
    (default: the checkout's ``study/reference_slices``; refused in an installed package)."""
    out = pathlib.Path(out) if out is not None else default_build_dir()
    known = specs()
    names = list(names or known)
    unknown = [n for n in names if n not in known]
    if unknown:
        raise registry.UserError(f"no reference slice for {', '.join(unknown)}; known: {', '.join(known)}")
    for grid in grids:
        _check_grid(grid)
    out.mkdir(parents=True, exist_ok=True)
    written = []
    with fanout.client(workers) as client, tempfile.TemporaryDirectory(dir=out, prefix=".reference-") as tmp:
        for name in names:
            for grid in grids:
                plan = slice_plan(name, grid)
                path = reference_path(name, out, grid)
                store = PartStore(pathlib.Path(tmp) / grid, name, plan.fingerprint)
                with store.lock():
                    execute.produce(plan, store, path, command, client=client, progress=progress,
                                    extra_attrs=_provenance(known[name], grid, plan, command))
                written.append(path)
    return written
