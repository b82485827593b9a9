"""The registry of named studies: what a study declares, and the table of studies by name.

A study (see ``study/CONTRACT.md``) is pure computation on numpy arrays plus metadata: a
``Study`` record holds everything the study layer says or does about it (settings, axes,
variables, its run-time estimate, its reference slices). This module only holds the
declarations; ``rimroll.study.settings`` resolves their settings (what each setting allows:
``rimroll.study.setting_table``), ``rimroll.study.plan`` and ``rimroll.study.execute`` run them.
Studies are found through the entry-point group ``rimroll.studies`` of the installed
distributions (rimroll's own: the modules of ``rimroll.workflows``); the study layer never
imports a studies module by name."""

from __future__ import annotations

import contextlib
import dataclasses
import importlib.util
import math
import os
import re
import sys
from collections.abc import Callable
from typing import Any

import numpy as np

from rimroll.solver.physics.params import FIELDS as PHYSICAL_KEYS
from rimroll.study.setting_table import SWEEP_KEYS

# PHYSICAL_KEYS: the settings that build the solver.Params of a run (every study accepts them);
# SWEEP_KEYS: the settings a study may declare sweepable (study.setting_table, Setting.sweep)

PLUGIN_ENV = "RIMROLL_STUDY_MODULES"
"""Environment variable: extra study modules (``.py`` paths, ``os.pathsep``-separated) to register,
e.g. test-only studies. Read in every process that loads the registry (dask workers too)."""

RESERVED_DIM_NAMES = frozenset({"indexers", "method", "tolerance", "drop", "missing_dims", "indexers_kwargs"})
"""Keyword parameters of xarray's ``Dataset.sel``/``Dataset.isel``: never a dimension name, or
``ds.sel(method=...)`` would silently mean the keyword, not the dimension (a test keeps this in
step with xarray's signatures)."""

_NAME = re.compile(r"^[A-Za-z_][A-Za-z0-9_]*$")
_STUDY_NAME = re.compile(r"^[A-Za-z_][A-Za-z0-9_-]*$")  # study names may also use '-' (realisable-cube)


class Terminated(KeyboardInterrupt):
    """SIGTERM to the ``study`` command (``timeout``, a batch system ending a job): stops a run as Ctrl-C
    does, saving what is finished, with exit status 143 (128 + SIGTERM)."""


def stopped_by(exc: BaseException) -> tuple[str, int]:
    """How a command stopped by ``exc`` says so, and its exit status: ("terminated (SIGTERM)", 143) for
    ``Terminated``, ("interrupted", 130) for Ctrl-C."""
    return ("terminated (SIGTERM)", 143) if isinstance(exc, Terminated) else ("interrupted", 130)


class UserError(ValueError):
    """An error the user can fix (bad name, bad setting, missing file): one line, exit 2.

    A ValueError, so that ``except ValueError`` catches a bad argument of the Python API
    (``rimroll.run``, ``rimroll.open``) as it does one of ``rimroll.solver``."""


@dataclasses.dataclass(frozen=True)
class Axis:
    """One swept coordinate with its metadata: a 1-D, finite, strictly monotonic array of
    numbers, or (a categorical axis such as ``scene``) distinct string labels.

    ``units`` is a CF/UDUNITS string ("rad", "s-1", "m s-1", "1"). ``aux`` holds auxiliary
    coordinates along this axis, ``{name: (values, units, long_name)}``: e.g. a ``scene`` axis
    carries the ``mu``, ``k_r`` and ``k_d`` of each scene. ``allow_inf``: +inf is a value of the
    axis (a friction coefficient ``mu``: inf never slips, so ``mu = 1, inf`` puts slipping and
    rolling only on one axis); NaN and -inf never are. ``comment``: the detail behind a short
    ``long_name`` (CF comment): xarray's plots label an axis with long_name and units, wrapped at 30
    characters, so a long_name of at most 24 keeps the label on one line.
    """

    name: str
    values: np.ndarray
    units: str
    long_name: str
    aux: dict = dataclasses.field(default_factory=dict)
    allow_inf: bool = False
    comment: str = ""

    def __post_init__(self):
        values = np.asarray(self.values)
        values = values.astype(str) if values.dtype.kind in "UO" else values.astype(float)
        object.__setattr__(self, "values", values)
        if not _NAME.match(self.name):
            raise ValueError(f"axis name {self.name!r} is not a valid identifier")
        if self.name in RESERVED_DIM_NAMES:
            raise ValueError(f"axis name {self.name!r} is a keyword of xarray's Dataset.sel/isel "
                             f"(reserved: {', '.join(sorted(RESERVED_DIM_NAMES))}); choose another name")
        if values.ndim != 1 or values.size < 2:
            raise ValueError(f"axis {self.name!r} needs at least 2 points in a 1-D array; got shape {values.shape}")
        if values.dtype.kind == "U":
            self._check_labels(values)
            return
        allowed = np.isfinite(values) | ((values == np.inf) if self.allow_inf else False)
        if not np.all(allowed):
            extra = " (+inf is allowed on this axis)" if self.allow_inf else ""
            raise ValueError(f"axis {self.name!r} has non-finite values{extra}")
        with np.errstate(invalid="ignore"):  # inf - inf (mu=inf,inf) is NaN: not monotonic, said below
            steps = np.diff(values)
        if not (np.all(steps > 0) or np.all(steps < 0)):
            raise ValueError(f"axis {self.name!r} must be strictly monotonic")
        self._check_aux(values)

    def _check_labels(self, values: np.ndarray) -> None:
        """A categorical axis: distinct labels, each a valid identifier (``ds.sel(scene="slipping")``)."""
        bad = [v for v in values if not _NAME.match(v)]
        if bad:
            raise ValueError(f"axis {self.name!r}: labels must be identifiers (letters, digits, '_'); got {bad}")
        if len(set(values)) != values.size:
            raise ValueError(f"axis {self.name!r}: labels must be distinct; got {list(values)}")
        self._check_aux(values)

    @property
    def categorical(self) -> bool:
        """True for an axis of string labels (a scene, an integrator), False for numbers."""
        return self.values.dtype.kind == "U"

    def _check_aux(self, values: np.ndarray) -> None:
        for aux_name, (aux_values, _units, _long_name) in self.aux.items():
            if not _NAME.match(aux_name) or np.shape(aux_values) != values.shape:
                raise ValueError(f"axis {self.name!r}: auxiliary coordinate {aux_name!r} needs a valid name "
                                 f"and one value per point ({values.size})")


@dataclasses.dataclass(frozen=True)
class Var:
    """One computed variable: name, CF units, long_name, dtype and (categorical) flags."""

    name: str
    units: str
    long_name: str
    dtype: str = "float64"
    flag_values: tuple | None = None
    flag_meanings: str | None = None
    outer: bool = False  # one value per point of the swept (outer) axes, e.g. an area over the grid
    standard_name: str | None = None  # CF standard name, where CF defines one (e.g. status_flag)
    comment: str | None = None  # the detail behind a short long_name (CF comment)
    tolerance: tuple | None = None  # (atol, rtol) of `study verify` for a continuous variable (None: the default)
    compared: bool = True  # False: never compared with a reference (integrator work, timings)
    pointwise: bool = True  # False: a point's value depends on the whole grid (a box, a sample), so `study
    # verify` compares it only on the reference's own grid

    def __post_init__(self):
        if not _NAME.match(self.name):
            raise ValueError(f"variable name {self.name!r} is not a valid identifier")
        np.dtype(self.dtype)  # raises TypeError on nonsense
        if (self.flag_values is None) != (self.flag_meanings is None):
            raise ValueError(f"variable {self.name!r}: give both flag_values and flag_meanings, or neither")
        if self.flag_values is not None and len(self.flag_values) != len(self.flag_meanings.split()):
            raise ValueError(f"variable {self.name!r}: {len(self.flag_values)} flag_values but "
                             f"{len(self.flag_meanings.split())} flag_meanings")

    @property
    def attrs(self) -> dict[str, Any]:
        """CF attributes of the variable."""
        out = {"units": self.units, "long_name": self.long_name}
        if self.standard_name:
            out["standard_name"] = self.standard_name
        if self.comment:
            out["comment"] = self.comment
        if self.flag_values is not None:
            out["flag_values"] = np.array(self.flag_values, dtype=self.dtype)
            out["flag_meanings"] = self.flag_meanings
        return out


def output_var(name: str, **changes) -> Var:
    """The variable of one output of ``simulate``, as ``solver.engine.outputs`` declares it (units,
    long_name, comment, dtype, flags, tolerance); ``changes`` overrides fields (e.g. ``outer``)."""
    from rimroll.solver.engine.outputs import output

    item = output(name)
    # the files follow CF-1.8, whose netCDF types have no 64-bit integers: the kernels' int64 counts
    # (steps of one lane, far below 2**31) are stored as int32 (study.plan.compute_chunk checks the range)
    dtype = "int32" if item.dtype == "int64" else item.dtype
    fields = dict(name=item.name, units=item.units, long_name=item.long_name, dtype=dtype,
                  flag_values=item.flag_values, flag_meanings=item.flag_meanings, standard_name=item.standard_name,
                  comment=item.comment or None, tolerance=item.tolerance, compared=item.compared)
    return Var(**{**fields, **changes})


def with_tolerances(variables: list, tolerances: dict) -> list:
    """``variables`` with the (atol, rtol) of ``study verify`` of each one ``tolerances`` names (name ->
    (atol, rtol)); ValueError for a name that is not among them or a tolerance that is not two numbers >= 0."""
    known = {v.name for v in variables}
    unknown = sorted(set(tolerances) - known)
    if unknown:
        raise ValueError(f"tolerances of unknown variables {unknown}; the variables are {sorted(known)}")
    for name, tol in tolerances.items():
        if len(tol) != 2 or not all(isinstance(t, (int, float)) and 0 <= t < math.inf for t in tol):
            raise ValueError(f"tolerance of {name!r} must be (atol, rtol), two finite numbers >= 0; got {tol!r}")
    return [dataclasses.replace(v, tolerance=tuple(map(float, tolerances[v.name]))) if v.name in tolerances else v
            for v in variables]


@dataclasses.dataclass(frozen=True)
class ReferenceSpec:
    """How the stored reference slices of a study are made (``study.reference``): the sub-grid of
    the default grid (``points``: grid axis -> number of values picked from the default axis, ends
    included; the other slice is the whole ``--quick`` grid), the reference's precision settings
    (``precise``: settings as Python values, e.g. ``{"rtol": 1e-12, "method": "dop853"}``; none: the
    study's own, a regression reference), what the files record as ``reference_method`` when the study
    has no ``method`` setting, and ``sets``: settings of the default slice alone (a cube's slice on a
    few of its settings, e.g. ``{"mu": (1, 2), "k_d": 0}``; a value held there is compared at that
    value of a file that sweeps it). Both are handed to ``study.plan.make_plan`` as they are."""

    points: dict
    precise: dict = dataclasses.field(default_factory=dict)
    method: str = "closed form (no integration)"
    sets: dict = dataclasses.field(default_factory=dict)

    def __post_init__(self):
        for field in ("precise", "sets"):
            if not isinstance(getattr(self, field), dict):
                raise ValueError(f"ReferenceSpec {field} must be a dict of settings, e.g. {{'rtol': 1e-12}}; got "
                                 f"{getattr(self, field)!r}")


@dataclasses.dataclass(frozen=True)
class Study:
    """A named study: settings, axes, variables, a pure ``compute`` and a ``plot``.

    ``axes(settings) -> [Axis]``; ``compute(coords, params, settings) -> {var: array}`` with
    coords the chunk's coordinates broadcast to the chunk's shape (axis order as declared);
    ``plot(dataset) -> matplotlib Figure``; ``chunks``: chunk length per axis name, or a function of
    the scalar settings returning that dict (an adaptive map needs its whole grid in one chunk).
    ``sweepable``: settings (of ``SWEEP_KEYS``) that ``--set KEY=a,b,c`` or
    ``KEY=start:stop:num`` turns into outer axes; a tuple default in ``settings`` sweeps by default.
    A variable with ``outer=True`` has the swept axes only, so the study's grid is one chunk.
    ``derive(dataset) -> {name: (dims, values, attrs)}``: variables computed once from the whole
    assembled grid (neighbours across chunks), added to the file before it is moved into place
    (``study.derived_variables``); ``derived_docs``: their rows in docs/studies.md, ``(name, units, meaning)``
    (``name`` may be a tuple of names sharing a row).
    ``ignores``: physical parameters (of ``PHYSICAL_KEYS``) that do not change the result, each
    with the reason; ``--set`` of one is refused rather than recorded as if it mattered.

    What ``study info`` estimates: ``cost``, seconds per grid point on one core, warm (measured with
    ``--quick``), growing in proportion to the setting ``cost_scale`` (if any; measured at its
    ``--quick`` value) and multiplied by ``cost_factor(settings)`` (if any: a setting that changes the
    work per point, such as another method); ``compiles``: the first run of an install compiles the simulation
    kernels. ``reference``: how its stored reference slices are made (None: the study has none).
    """

    name: str
    title: str
    settings: dict
    axes: Callable[[dict], list]
    variables: list
    compute: Callable
    plot: Callable | None = None
    quick: dict = dataclasses.field(default_factory=dict)
    chunks: dict | Callable[[dict], dict] = dataclasses.field(default_factory=dict)
    sweepable: tuple = ()
    derive: Callable | None = None
    ignores: dict = dataclasses.field(default_factory=dict)  # physical key -> why the study does not use it
    cost: float | None = None  # seconds per grid point on one core (None: no estimate)
    cost_scale: str | None = None  # the setting the cost per point is proportional to
    cost_factor: Callable[[dict], float] | None = None  # a multiplier from the run's settings (another method)
    compiles: bool = False  # the first run of an install compiles the simulation kernels (once, announced)
    reference: ReferenceSpec | None = None  # its stored reference slices
    derived_docs: tuple = ()  # (name or names, units, meaning) of what ``derive`` adds, for the docs
    check: Callable[[dict, Any], None] | None = None  # check(settings, params): ValueError for a derived
    # quantity the settings make impossible (swept settings as tuples), before any work

    def __post_init__(self):
        if not _STUDY_NAME.match(self.name):
            raise ValueError(f"study name {self.name!r} is not a valid name (letters, digits, '_', '-')")
        bad = set(self.sweepable) - set(SWEEP_KEYS)
        if bad:
            raise ValueError(f"study {self.name!r}: sweepable {sorted(bad)} not among {SWEEP_KEYS}")
        for key, value in {**self.settings, **self.quick}.items():
            if isinstance(value, (tuple, list)) and key not in self.sweepable:
                raise ValueError(f"study {self.name!r}: setting {key!r} has a list of values but is not sweepable")
        unknown = set(self.quick) - set(self.settings) - set(PHYSICAL_KEYS)
        if unknown:
            raise ValueError(f"study {self.name!r}: quick settings {sorted(unknown)} are not settings")
        if set(self.ignores) - set(PHYSICAL_KEYS) or set(self.ignores) & set(self.sweepable):
            raise ValueError(f"study {self.name!r}: ignores {sorted(self.ignores)} must be physical keys, not swept")
        names = [v.name for v in self.variables]
        if not names or len(set(names)) != len(names):
            raise ValueError(f"study {self.name!r}: variable names must be non-empty and unique; got {names}")
        self._check_estimate()

    def core_seconds(self, points: float, settings: dict) -> float | None:
        """The cost model: seconds of one core for ``points`` grid points at ``settings`` (``cost`` per
        point, in proportion to the setting ``cost_scale`` against its ``--quick`` value, the largest
        of a swept one, times ``cost_factor(settings)``); None for a study without a cost."""
        if self.cost is None:
            return None
        seconds = self.cost * points
        if self.cost_scale:
            value = settings.get(self.cost_scale)
            value = max(value) if isinstance(value, tuple) else value
            measured = self.quick.get(self.cost_scale, self.settings[self.cost_scale])
            with contextlib.suppress(TypeError, ValueError, ZeroDivisionError):
                seconds *= float(value) / float(measured)
        if self.cost_factor is not None:
            seconds *= float(self.cost_factor(settings))
        return seconds

    def _check_estimate(self) -> None:
        if self.cost is not None and not self.cost > 0:
            raise ValueError(f"study {self.name!r}: cost must be > 0 seconds per point; got {self.cost!r}")
        if self.cost_factor is not None and (self.cost is None or not callable(self.cost_factor)):
            raise ValueError(f"study {self.name!r}: cost_factor must be a function of the settings, with a cost")
        if self.cost_scale is not None and (self.cost is None or self.cost_scale not in self.settings):
            raise ValueError(f"study {self.name!r}: cost_scale {self.cost_scale!r} needs a cost and must be a setting")
        if self.reference is not None and not isinstance(self.reference, ReferenceSpec):
            raise ValueError(f"study {self.name!r}: reference must be a ReferenceSpec")


_REGISTRY: dict[str, Study] = {}


def register(study: Study) -> Study:
    """Add a study to the registry (a second study with the same name is an error)."""
    if study.name in _REGISTRY and _REGISTRY[study.name] is not study:
        raise ValueError(f"a study named {study.name!r} is already registered")
    _REGISTRY[study.name] = study
    return study


ENTRY_POINT_GROUP = "rimroll.studies"
"""Entry-point group naming the modules that register studies on import, one entry per study
named as the study (rimroll's own: ``fig11 = "workflows.outcome_grids"``, ... in pyproject.toml),
so that ``get`` imports only the module it needs; another package can add studies the same
way (an entry whose name is no study of its module is still loaded by ``names``)."""


def study_entry_points() -> list:
    """The installed ``rimroll.studies`` entry points (``importlib.metadata``)."""
    from importlib.metadata import entry_points

    return list(entry_points(group=ENTRY_POINT_GROUP))


_loaded_entry_points = False


def _load_studies() -> None:
    """Import the modules of the entry points (once per process: a scan costs milliseconds) and
    of ``$RIMROLL_STUDY_MODULES``; ``UserError`` if they register no study at all."""
    global _loaded_entry_points
    if not _loaded_entry_points:
        for ep in study_entry_points():
            _load_entry_point(ep)
        _loaded_entry_points = True
    for path in filter(None, os.environ.get(PLUGIN_ENV, "").split(os.pathsep)):
        _load_module_file(path)
    if not _REGISTRY:
        raise UserError(f"no studies found: no installed package declares the entry-point group "
                        f"{ENTRY_POINT_GROUP!r} (install rimroll into this Python environment with "
                        "pip install . or pip install -e .)")


def _load_entry_point(ep) -> None:
    """Import one entry point's module (its ``register`` calls run on import). An import that Ctrl-C
    broke is an interrupt, not a broken module: some compiled extensions (matplotlib's) turn the
    KeyboardInterrupt of their initialisation into ImportError("initialization failed")."""
    try:
        ep.load()
    except ImportError as exc:
        if interrupted(exc):
            raise KeyboardInterrupt from exc
        raise UserError(f"cannot load the studies of entry point {ep.name} = {ep.value} "
                        f"(group {ENTRY_POINT_GROUP}): {exc}") from None


def interrupted(exc: BaseException) -> bool:
    """Whether a KeyboardInterrupt is among the causes and contexts of ``exc`` (an ImportError of a
    compiled extension whose initialisation Ctrl-C broke)."""
    seen = set()
    while exc is not None and id(exc) not in seen:
        if isinstance(exc, KeyboardInterrupt):
            return True
        seen.add(id(exc))
        exc = exc.__cause__ or exc.__context__
    return False


def _load_module_file(path: str) -> None:
    """Import the module at ``path`` once per process (its ``register`` calls run on import)."""
    name = "rimroll_plugin_" + re.sub(r"\W", "_", os.path.abspath(path))
    if name in sys.modules:
        return
    spec = importlib.util.spec_from_file_location(name, path)
    if spec is None or spec.loader is None:
        raise UserError(f"{PLUGIN_ENV}: cannot import {path}")
    module = importlib.util.module_from_spec(spec)
    sys.modules[name] = module
    spec.loader.exec_module(module)


def names() -> list[str]:
    """Names of all registered studies, sorted."""
    _load_studies()
    return sorted(_REGISTRY)


def natural_order(names) -> list[str]:
    """fig3, fig5, ..., fig9, fig11, ... (numbers compared as numbers), then the other studies."""

    def key(name):
        parts = [int(t) if t.isdigit() else t for t in re.split(r"(\d+)", name)]
        return (0 if re.fullmatch(r"fig\d+", name) else 1, [(isinstance(t, str), t) for t in parts])

    return sorted(names, key=key)


def known_names() -> list[str]:
    """The names of the studies, sorted, read from the entry points (one per study, named as the study) and
    the studies registered so far, without importing a studies module: a misspelt name is refused at once.
    With none, the studies are loaded (:class:`UserError` "no studies found" where there are none at all)."""
    found = {ep.name for ep in study_entry_points()} | set(_REGISTRY)
    if not found:
        _load_studies()
        found = set(_REGISTRY)
    return sorted(found)


def get(name: str) -> Study:
    """The registered study called ``name``; ``UserError`` listing known names otherwise.

    Imports only the module of the entry point named ``name`` when there is one (a warm
    ``study run fig11`` then skips the other families' imports). A name that is no entry point's is refused
    without importing any studies module (unless ``$RIMROLL_STUDY_MODULES`` names modules to search)."""
    if name not in _REGISTRY and not _loaded_entry_points:
        for ep in study_entry_points():
            if ep.name == name:
                _load_entry_point(ep)
    if name not in _REGISTRY and (_loaded_entry_points or os.environ.get(PLUGIN_ENV)):
        _load_studies()
    if name not in _REGISTRY:
        raise UserError(f"unknown study {name!r}; known studies: {', '.join(known_names()) or 'none'}")
    return _REGISTRY[name]
