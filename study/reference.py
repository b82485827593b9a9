"""Stored reference slices: small, precise results of every map and outcome study.

The slices ship inside the package (``study/reference_slices/<study>.nc``, package data found
with ``importlib.resources``), so ``study verify`` works after ``pip install .``.
``study reference --build`` writes them to ``--out DIR``; without ``--out`` only in a source
checkout (never into an installed package): each
study on a coarse **sub-grid of its default grid** (every axis: ``points`` values picked from
the default axis, ends included: a 36 x 24 sub-grid of each outcome section in all four scenes,
121 x 80 of the steady maps, 40 x 30 of fig9), so a full-resolution run shares every reference
point; the outcome sections at rtol = 1e-12 with DOP853 (``PRECISE``). The regression
tests (``tests/test_reference_slices.py``) recompute each slice at the study's default
settings (:func:`recompute`) and compare with ``study.compare``; ``study verify FILE``
compares any result file with the slice of its study.

Every file records how it was made in global attributes: ``reference_command``,
``reference_settings`` (the ``--quick --set ...`` of the run), ``reference_rtol``,
``reference_atol``, ``reference_method`` and the usual provenance (``rimroll_version``,
``git_revision``, ``created``, ``history``).
"""

from __future__ import annotations

import contextlib
import dataclasses
import importlib.resources
import os
import pathlib
import shlex
import tempfile

import numpy as np
import xarray as xr

from study import fanout, io, registry
from study.assemble import assemble
from study.dataset import coords_of, global_attrs
from study.derived import with_derived
from study.parts import PartStore
from study.plan import Plan, compute_chunk, make_plan
from study.progress import ProgressLine

ENV_DIR = "RIMROLL_REFERENCE_DIR"
PACKAGE_DIR = "reference_slices"  # package data of ``study``
PRECISE = ("rtol=1e-12", "atol=1e-14", "method=dop853")  # outcome studies: the engine's tightest setting


@dataclasses.dataclass(frozen=True)
class Spec:
    """How one reference slice is made: ``--quick`` plus ``sets`` (grid) plus ``precise``."""

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
    return pathlib.Path(str(importlib.resources.files("study").joinpath(PACKAGE_DIR)))


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


def reference_path(study: str, directory=None) -> pathlib.Path:
    return pathlib.Path(directory or reference_dir()) / f"{study}.nc"


def plan_of(name: str, precise: bool) -> Plan:
    """The plan of a slice: the reference (``precise``) or the study's defaults on the same grid."""
    spec = SPECS[name]
    return make_plan(registry.get(name), sets=[*spec.sets, *(spec.precise if precise else ())])


def recompute(name: str, precise: bool = False, workers: int = 2) -> xr.Dataset:
    """The slice of ``name`` computed in memory (no files), derived variables included."""
    from concurrent.futures import ThreadPoolExecutor

    plan = plan_of(name, precise)
    study = plan.study
    arrays = {v.name: np.empty(plan.outer_shape if v.outer else plan.shape, dtype=v.dtype) for v in study.variables}
    with ThreadPoolExecutor(max_workers=workers) as pool:
        for k, part in enumerate(pool.map(lambda k: compute_chunk(plan.job(k)), range(plan.n_chunks))):
            region = plan.region(k)
            for v in study.variables:
                arrays[v.name][region[: len(plan.outer)] if v.outer else region] = part[v.name]
    dims = [a.name for a in plan.axes]
    outer_dims = dims[: len(plan.outer)]
    data = {v.name: (outer_dims if v.outer else dims, arrays[v.name], v.attrs) for v in study.variables}
    attrs = global_attrs(study, plan.params, plan.settings, f"study.reference.recompute({name!r}, precise={precise})")
    return with_derived(study, xr.Dataset(data, coords=coords_of(plan.axes), attrs=attrs))


def _provenance(name: str, plan: Plan, command: str) -> dict:
    spec = SPECS[name]
    s = plan.settings
    return {
        "reference_command": command,
        "reference_settings": shlex.join([*(f"--set={x}" for x in spec.precise)]) + " on the sub-grid "
                              + ", ".join(f"{k}: {n} of the default values (ends included)" for k, n in spec.points.items()),
        "reference_rtol": str(s.get("rtol", "n/a")),
        "reference_atol": str(s.get("atol", "n/a")),
        "reference_method": str(s.get("method", spec.method)),
        "reference_purpose": "stored reference slice of rimroll: regression tests and `study verify`",
    }


def build(out=None, names=None, workers: int | None = None, command: str = "study reference --build",
          progress: bool = False) -> list[pathlib.Path]:
    """Compute the reference slices ``names`` (default: all) into ``out`` (default: the checkout's
    ``study/reference_slices``; refused in an installed package)."""
    out = pathlib.Path(out) if out is not None else default_build_dir()
    names = list(names or SPECS)
    unknown = [n for n in names if n not in SPECS]
    if unknown:
        raise registry.UserError(f"no reference slice for {', '.join(unknown)}; known: {', '.join(SPECS)}")
    out.mkdir(parents=True, exist_ok=True)
    written = []
    with fanout.client(workers) as client, tempfile.TemporaryDirectory(dir=out, prefix=".reference-") as tmp:
        for name in names:
            plan = plan_of(name, precise=True)
            store = PartStore(tmp, name, plan.fingerprint)
            with store.lock():
                line = ProgressLine(plan.n_chunks, name, enabled=progress)
                fanout.run(plan, store, list(range(plan.n_chunks)), client, line)
                attrs = global_attrs(plan.study, plan.params, plan.settings, command,
                                     tuple(a.name for a in plan.outer))
                attrs.update(_provenance(name, plan, command))
                path = out / f"{name}.nc"
                assemble(plan, store, path, attrs)
                store.remove()
            written.append(path)
    return written


@contextlib.contextmanager
def open_reference(study: str, directory=None):
    """The stored slice of ``study`` (loaded), or None if there is none."""
    path = reference_path(study, directory)
    if not path.is_file():
        yield None
        return
    ds = io.open_result(path)
    try:
        yield ds
    finally:
        ds.close()
