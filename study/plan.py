"""The plan of one run: resolved settings, outer (swept) and grid axes, chunks, per-chunk jobs.

Every study runs through a plan: ``study run``, the reference slices and the in-memory results
of ``study.execute.compute`` all make one with :func:`make_plan` (settings resolved by
``study.settings``) and hand it to ``study.execute``.

The cube's dimensions are the outer axes (one per swept setting) followed by the study's grid
axes. A chunk is one point of the outer axes times a block of the grid (outer axes are chunked
by 1, so a chunk's Params and settings are constants); chunks are numbered in C order. The
on-disk netCDF chunks are the same blocks. :meth:`Plan.fingerprint` hashes everything that
determines the numbers of a chunk, so a part file of another input is never reused.
"""

from __future__ import annotations

import dataclasses
import functools
import hashlib
import inspect
import json
import math
import pathlib
import re
import sys

import numpy as np

from rimroll import solver
from rimroll.study import checks
from rimroll.study.dataset import rimroll_version
from rimroll.study.registry import PHYSICAL_KEYS, Axis, Study, UserError
from rimroll.study.settings import base_settings, params_from, resolve

DEFAULT_CHUNK = 64  # points per chunk along the first grid axis when the study does not say
STORAGE_VALUES = 2**20  # values per on-disk chunk, at most: 1 MiB of int8 ... 8 MiB of float64


@dataclasses.dataclass(frozen=True)
class ChunkJob:
    """Everything a worker needs to compute chunk ``k`` (picklable: the study goes by name)."""

    study: str
    k: int
    settings: dict
    params: solver.Params
    grid: tuple  # 1-D coordinate arrays of the chunk's grid block, one per grid axis
    n_outer: int
    digest: str = ""  # the client's code_digest of the study: a worker running other code refuses the job


class CodeMismatch(UserError):
    """A worker's code differs from the client's (another rimroll on its path): it refuses the chunk."""


@dataclasses.dataclass(frozen=True)
class Plan:
    study: Study
    settings: dict  # resolved; a swept key holds its tuple of values
    params: solver.Params  # Params of the scalar settings (swept keys at their first value)
    outer: tuple  # Axis per swept setting
    grid: tuple  # the study's grid axes
    block: tuple  # chunk length per grid axis
    backend: str | None = None  # solver backend of a study with a ``backend`` setting, as resolved here

    @property
    def axes(self) -> list[Axis]:
        return [*self.outer, *self.grid]

    @property
    def shape(self) -> tuple[int, ...]:
        return tuple(a.values.size for a in self.axes)

    @property
    def outer_shape(self) -> tuple[int, ...]:
        return tuple(a.values.size for a in self.outer)

    @functools.cached_property
    def counts(self) -> tuple[int, ...]:
        """Chunks along each dimension."""
        grid = tuple(-(-a.values.size // b) for a, b in zip(self.grid, self.block))
        return self.outer_shape + grid

    @property
    def n_chunks(self) -> int:
        return math.prod(self.counts)

    @property
    def nc_chunks(self) -> tuple[int, ...]:
        """Compute chunk shape of a full-cube variable (outer axes by 1, then the grid block)."""
        return (1,) * len(self.outer) + tuple(self.block)

    @functools.cached_property
    def storage(self) -> tuple[int, ...]:
        """On-disk (netCDF) chunk shape of a full-cube variable: about :data:`STORAGE_VALUES` values,
        each length a multiple or a divisor of the compute chunk's (:func:`storage_chunks`)."""
        return storage_chunks(self.shape, self.nc_chunks)

    def region(self, k: int) -> tuple[slice, ...]:
        """Slices of the full cube covered by chunk ``k``."""
        idx = np.unravel_index(k, self.counts)
        n = len(self.outer)
        out = [slice(int(i), int(i) + 1) for i in idx[:n]]
        for i, a, b in zip(idx[n:], self.grid, self.block):
            out.append(slice(int(i) * b, min((int(i) + 1) * b, a.values.size)))
        return tuple(out)

    def expected(self, k: int) -> dict[str, tuple[tuple[int, ...], np.dtype]]:
        """Shape and dtype of every variable in chunk ``k``'s part."""
        region = self.region(k)
        full = tuple(s.stop - s.start for s in region)
        outer = full[: len(self.outer)]
        return {v.name: (outer if v.outer else full, np.dtype(v.dtype)) for v in self.study.variables}

    def outer_region(self, k: int) -> tuple[slice, ...]:
        return self.region(k)[: len(self.outer)]

    def settings_at(self, k: int) -> tuple[dict, solver.Params]:
        """Scalar settings and Params of chunk ``k`` (swept values substituted)."""
        region = self.region(k)
        s = base_settings(self.settings)
        for a, sl in zip(self.outer, region):
            value = a.values[sl.start]
            s[a.name] = str(value) if a.categorical else float(value)  # a swept label (geometry) or number
        params = params_from(s) if self.outer else self.params
        s.update(params.as_dict())
        return s, params

    def job(self, k: int) -> ChunkJob:
        region = self.region(k)
        s, params = self.settings_at(k)
        grid = tuple(a.values[sl] for a, sl in zip(self.grid, region[len(self.outer):]))
        return ChunkJob(self.study.name, k, s, params, grid, len(self.outer), self.digest)

    @functools.cached_property
    def digest(self) -> str:
        """:func:`code_digest` of the study on this machine, carried by every :class:`ChunkJob`."""
        return code_digest(self.study)

    @functools.cached_property
    def fingerprint(self) -> str:
        """16 hex digits: study, settings, Params, axes, variables, chunking, the release of rimroll and the
        code digest."""
        h = hashlib.sha256()

        def put(obj):
            h.update(json.dumps(obj, sort_keys=True, default=repr).encode())

        put({"study": self.study.name, "settings": {k: repr(v) for k, v in self.settings.items()},
             "params": self.params.as_dict(), "block": list(self.block), "rimroll": release(rimroll_version()),
             "variables": [(v.name, v.dtype, v.outer) for v in self.study.variables]})
        for a in self.axes:
            put([a.name, a.units, sorted(a.aux)])
            h.update(np.ascontiguousarray(a.values).tobytes())  # float64 numbers or string labels
            for values, *_ in a.aux.values():
                h.update(np.ascontiguousarray(values).tobytes())
        h.update(self.digest.encode())
        return h.hexdigest()[:16]


def storage_chunks(shape: tuple[int, ...], block: tuple[int, ...], target: int | None = None) -> tuple[int, ...]:
    """On-disk chunk shape for a variable of ``shape`` computed in chunks of ``block``: at most
    ``target`` values (default :data:`STORAGE_VALUES`; more only when a single row along the last
    dimension is more), as close to it as the shape allows.

    Each length is a multiple of the compute block's along that dimension (small compute chunks,
    e.g. the one point of an outer axis: storage chunks span several, from the last dimension
    on) or a divisor of it (a compute chunk larger than ``target``, e.g. a whole GPU section:
    split from the first dimension on), or the whole dimension. So a storage chunk never straddles
    two compute chunks partly, and the assembly writes whole storage chunks (``study.assemble``).
    """
    target = STORAGE_VALUES if target is None else target
    sb = [max(1, min(int(b), int(n))) for b, n in zip(block, shape)]
    for d in range(len(sb)):  # too large: split the first dimensions into divisors of their block
        rest = math.prod(sb) // sb[d]
        if rest * sb[d] <= target:
            break
        bound = max(1, target // rest)
        sb[d] = max(k for k in _divisors(sb[d]) if k <= bound)
    for d in reversed(range(len(sb))):  # too small: grow the last dimensions by multiples of their block
        size = math.prod(sb)
        if size * 2 > target:
            break
        if sb[d] < shape[d]:
            sb[d] = min(int(shape[d]), sb[d] * max(1, target // size))
    return tuple(sb)


def _divisors(n: int) -> list[int]:
    small = [k for k in range(1, math.isqrt(n) + 1) if n % k == 0]
    return sorted({*small, *(n // k for k in small)})


def release(version: str) -> str:
    """The release part of a version, '0.1' of '0.1.dev173+g1a2b3c4.d20260101': what the fingerprint
    keeps of it (between releases the code digest tells the code apart, so a new commit of the
    documentation does not make every result another run)."""
    match = re.match(r"\d+(\.\d+)*", version)
    return match.group(0) if match else version


def code_digest(study: Study) -> str:
    """Hash of the solver's sources (every ``.py`` of ``rimroll.solver`` and its subpackages: the digest
    that also keys the kernel cache, ``solver._jit.SOURCES_DIGEST``) and of the module defining the
    study's ``compute``."""
    from rimroll.solver import _jit

    h = hashlib.sha256(_jit.SOURCES_DIGEST.encode())
    try:
        f = pathlib.Path(inspect.getsourcefile(study.compute))
    except TypeError:
        return h.hexdigest()
    h.update(f.name.encode())
    h.update(f.read_bytes())
    for path in _sibling_sources(study.compute):
        h.update(path.name.encode())
        h.update(path.read_bytes())
    return h.hexdigest()


def _sibling_sources(compute) -> list[pathlib.Path]:
    """Source files of the modules whose names the module of ``compute`` imported, of its own package or
    of rimroll outside the solver (whose every source is in ``_jit.SOURCES_DIGEST``): e.g.
    ``study.outcome_sections`` for ``workflows.outcome_grids``, ``peer_models.heyoka_rolling`` for
    ``workflows.work_precision``. Their code decides the numbers too (the study layer's modules a study
    names, such as its registry, come along: a change there also makes new fingerprints)."""
    module = inspect.getmodule(compute)
    if module is None or "." not in module.__name__:
        return []
    package = module.__name__.rsplit(".", 1)[0] + "."
    names = set()
    for obj in vars(module).values():
        name = obj.__name__ if inspect.ismodule(obj) else getattr(obj, "__module__", None)
        shared = isinstance(name, str) and name.startswith("rimroll.") and not name.startswith("rimroll.solver")
        if isinstance(name, str) and (name.startswith(package) or shared) and name != module.__name__:
            names.add(name)
    files = []
    for name in sorted(names):
        source = getattr(sys.modules.get(name), "__file__", None)
        if source and source.endswith(".py"):
            files.append(pathlib.Path(source))
    return files


def resolve_backend(settings: dict, local: bool = True) -> str | None:
    """The concrete backend ('cpu' or 'cuda') of a study's ``backend`` setting, written back into
    ``settings`` (so the fingerprint and the attributes say what ran); None without the setting.

    'auto' is decided here, on the machine that plans the run. 'cuda' is checked here too when
    the run is ``local`` (a missing extra or device is one line before any work); on a
    ``--scheduler`` cluster the workers check it.
    """
    if "backend" not in settings:
        return None
    from rimroll.solver.engine import backends

    try:
        if settings["backend"] == "auto" or (settings["backend"] == "cuda" and local):
            settings["backend"] = backends.resolve(settings["backend"]).name
    except backends.BackendUnavailable as exc:
        raise UserError(str(exc)) from None
    return settings["backend"]


def make_plan(study: Study, quick: bool = False, values=None, local: bool = True) -> Plan:
    """Resolve the settings ``values`` (``{key: value}``, Python values: a number, a label, a switch, or
    a list, tuple, range or numpy array of several, a sweep; ``study.settings``) into a validated
    :class:`Plan` (UserError if bad). The command line's ``--set`` text becomes such values once, in
    ``study.cli_text.setting_values``.

    ``local``: the run computes on this machine (not on a ``--scheduler`` cluster); see
    :func:`resolve_backend`. With a GPU backend the numeric grid axes are not split: a chunk is a
    whole section (one launch), however the study chunks its grid for the CPU.
    """
    r = resolve(study, quick, values)
    backend = resolve_backend(r.settings, local)
    whole = any(v.outer for v in study.variables)
    chunks = study.chunks(base_settings(r.settings)) if callable(study.chunks) else study.chunks
    block = []
    for i, a in enumerate(r.grid):
        n = a.values.size
        size = n if whole else chunks.get(a.name, DEFAULT_CHUNK if i == 0 else n)
        if backend == "cuda" and not a.categorical:
            size = n  # a whole section per chunk: one launch
        block.append(max(1, min(int(size), n)))
    plan = Plan(study, r.settings, r.params, r.outer, r.grid, tuple(block), backend)
    checks.check_size(study.name, plan.n_chunks, math.prod(plan.shape))
    return plan


def _narrowed(values: np.ndarray, dtype: str, name: str) -> np.ndarray:
    """``values`` as ``dtype``; an integer that does not fit the stored integer type is an error, not a
    wrapped number (int64 counts are stored as int32, ``registry.output_var``)."""
    kind = np.dtype(dtype)
    if kind.kind in "iu" and values.dtype.kind in "iu" and values.size:
        info = np.iinfo(kind)
        if values.min() < info.min or values.max() > info.max:
            raise OverflowError(f"variable {name!r}: values {values.min()}..{values.max()} do not fit its {dtype}")
    return values.astype(kind)


def check_digest(study: Study, expected: str) -> None:
    """:class:`CodeMismatch` (one line naming both digests and the worker) unless this process's
    :func:`code_digest` of ``study`` is ``expected``, the client's."""
    mine = code_digest(study)
    if mine == expected:
        return
    try:
        from distributed import get_worker

        where = f"worker {get_worker().address}"
    except (ImportError, ValueError):  # not inside a dask worker
        where = "this process"
    raise CodeMismatch(f"{where} refuses chunks of {study.name}: its code digest {mine[:16]} differs from the "
                       f"client's {expected[:16]} (another rimroll or solver on the worker's path); run the "
                       "same code on every worker")


def compute_chunk(job: ChunkJob) -> dict[str, np.ndarray]:
    """Run the study's ``compute`` on one chunk; arrays shaped like the chunk's region.

    Module-level and driven by a :class:`ChunkJob` only, so dask.distributed can ship it:
    the worker looks the study up in its own registry.
    """
    from rimroll.study import registry

    study = registry.get(job.study)
    if job.digest:
        check_digest(study, job.digest)
    coords = np.meshgrid(*job.grid, indexing="ij") if job.grid else []
    grid_shape = tuple(g.size for g in job.grid)
    out = study.compute(coords, job.params, job.settings)
    result = {}
    for var in study.variables:
        if var.name not in out:
            raise KeyError(f"study {study.name!r}: compute returned no {var.name!r}")
        shape = () if var.outer else grid_shape
        values = _narrowed(np.broadcast_to(np.asarray(out[var.name]), shape), var.dtype, var.name)
        # np.array, not np.ascontiguousarray: that one turns a 0-d result (no swept axis) into shape (1,)
        result[var.name] = np.array(values.reshape((1,) * job.n_outer + shape), order="C")
    return result


__all__ = ["ChunkJob", "CodeMismatch", "Plan", "check_digest", "compute_chunk", "make_plan", "PHYSICAL_KEYS"]
