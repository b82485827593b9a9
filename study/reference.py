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

Both at the study's settings, the outcome sections at rtol = 1e-12 with DOP853 (``PRECISE``).
``study verify FILE`` compares a file with the slice of its study that shares the most points
with it (:func:`candidates`); the regression tests (``tests/test_reference_slices.py``)
recompute each slice at the study's default precision (:func:`recompute`) and compare with
``study.compare``. ``study reference --build`` writes ``--out DIR``; without ``--out`` only in a
source checkout (never into an installed package).

Every file records how it was made in global attributes: ``reference_command``,
``reference_settings`` (the ``--quick``/``--set`` of the run), ``reference_rtol``,
``reference_atol``, ``reference_method`` and the usual provenance (``rimroll_version``,
``git_revision``, ``created``, ``history``).
"""

from __future__ import annotations

import dataclasses
import importlib.resources
import os
import pathlib
import shlex
import tempfile

import numpy as np
import xarray as xr

from rimroll.study import execute, fanout, registry
from rimroll.study.parts import PartStore
from rimroll.study.plan import Plan, make_plan

ENV_DIR = "RIMROLL_REFERENCE_DIR"
PACKAGE_DIR = "reference_slices"  # package data of ``rimroll.study``
PRECISE = ("rtol=1e-12", "atol=1e-14", "method=dop853")  # outcome studies: the engine's tightest setting
GRIDS = ("default", "quick")
"""The two slices of a study: a sub-grid of its default grid, and its whole ``--quick`` grid
(in the subdirectory ``quick/``)."""


@dataclasses.dataclass(frozen=True)
class Spec:
    """How the reference slices of one study are made: the default grid's sub-grid (``points``)
    or the ``--quick`` grid, plus the reference's ``precise`` settings."""

    name: str
    points: dict  # grid axis -> number of values picked from the default axis (ends included)
    precise: tuple = ()  # precision settings of the reference only
    method: str = "closed form (no integration)"  # what reference_method records when no ``method`` setting

    @property
    def sets(self) -> tuple:
        """``--set AXIS=v1,v2,...`` of the sub-grid (exact values of the default axes)."""
        full = {a.name: a.values for a in make_plan(registry.get(self.name)).grid}
        out = []
        for axis, n in self.points.items():
            idx = np.unique(np.round(np.linspace(0, full[axis].size - 1, n)).astype(int))
            out.append(f"{axis}=" + ",".join(repr(float(v)) for v in full[axis][idx]))
        return tuple(out)

    def plan(self, grid: str = "default", precise: bool = True) -> Plan:
        """The plan of a slice (``precise``: the reference; else the study's own precision on the
        same grid)."""
        _check_grid(grid)
        extra = self.precise if precise else ()
        if grid == "quick":
            return make_plan(registry.get(self.name), quick=True, sets=extra)
        return make_plan(registry.get(self.name), sets=[*self.sets, *extra])


MAPS = {"beta0": 121, "omega30": 80}
SECTION = {"beta": 24, "omega1": 36}
SPECS = {s.name: s for s in (
    Spec("fig3", MAPS), Spec("fig5", MAPS), Spec("fig6", MAPS), Spec("fig7", MAPS), Spec("fig8", MAPS),
    Spec("fig9", {"rho_over_R": 40, "j": 30},
         method="solver.floquet fixed-step RK8 in theta (~1e-13 relative in tr M)"),
    Spec("fig11", SECTION, PRECISE), Spec("fig12", SECTION, PRECISE), Spec("fig13", SECTION, PRECISE),
)}


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
    plan = SPECS[name].plan(grid, precise)
    return execute.compute(plan, f"study.reference.recompute({name!r}, precise={precise}, grid={grid!r})", workers)


def _provenance(spec: Spec, grid: str, plan: Plan, command: str) -> dict:
    s = plan.settings
    sets = shlex.join([*(f"--set={x}" for x in spec.precise)])
    if grid == "quick":
        how = " ".join(filter(None, ["--quick", sets])) + " on the whole --quick grid"
    else:
        how = sets + " on the sub-grid " + ", ".join(f"{k}: {n} of the default values (ends included)"
                                                     for k, n in spec.points.items())
    return {
        "reference_command": command,
        "reference_settings": how,
        "reference_rtol": str(s.get("rtol", "n/a")),
        "reference_atol": str(s.get("atol", "n/a")),
        "reference_method": str(s.get("method", spec.method)),
        "reference_purpose": "stored reference slice of rimroll: regression tests and `study verify`",
    }


def build(out=None, names=None, workers: int | None = None, command: str = "study reference --build",
          progress: bool = False, grids=GRIDS) -> list[pathlib.Path]:
    """Compute the slices ``names`` (default: all) on ``grids`` (default: both) into ``out``
    (default: the checkout's ``study/reference_slices``; refused in an installed package)."""
    out = pathlib.Path(out) if out is not None else default_build_dir()
    names = list(names or SPECS)
    unknown = [n for n in names if n not in SPECS]
    if unknown:
        raise registry.UserError(f"no reference slice for {', '.join(unknown)}; known: {', '.join(SPECS)}")
    for grid in grids:
        _check_grid(grid)
    out.mkdir(parents=True, exist_ok=True)
    written = []
    with fanout.client(workers) as client, tempfile.TemporaryDirectory(dir=out, prefix=".reference-") as tmp:
        for name in names:
            for grid in grids:
                plan = SPECS[name].plan(grid)
                path = reference_path(name, out, grid)
                store = PartStore(pathlib.Path(tmp) / grid, name, plan.fingerprint)
                with store.lock():
                    execute.produce(plan, store, path, command, client=client, progress=progress,
                                    extra_attrs=_provenance(SPECS[name], grid, plan, command))
                written.append(path)
    return written
