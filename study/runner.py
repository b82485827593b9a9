"""Settings, Params and axes of a study, and an in-memory evaluation of its grid with dask.

``study run`` goes through ``study.plan`` / ``study.fanout`` (sweeps, parts on disk, resume);
:func:`evaluate` is the in-memory path for small grids in Python.

Settings resolve as defaults < ``--quick`` < ``--set``. The physical keys (r R a m j mu g
k_r k_d, SI units) build a :class:`solver.Params`; a bad value gives Params' ValueError
message as a :class:`UserError`. The outer-product grid of the study's axes is split into
chunks; each chunk is one dask task evaluated with the threaded scheduler (kernels release
the GIL), one worker per core unless told otherwise.
"""

from __future__ import annotations

import itertools
import os

import dask
from dask.callbacks import Callback
import numpy as np

import solver
from study.progress import ProgressLine
from study.registry import Axis, Study, UserError

DEFAULT_CHUNK = 64  # points per chunk along the first axis when the study does not say


def default_settings(study: Study) -> dict:
    """The study's settings plus every physical parameter at its Table 1 value."""
    out = solver.Params().as_dict()
    out.update(study.settings)
    return out


def parse_set(item: str) -> tuple[str, str]:
    """Split ``KEY=VALUE``; :class:`UserError` when malformed."""
    key, sep, value = item.partition("=")
    key, value = key.strip(), value.strip()
    if not sep or not key or not value:
        raise UserError(f"malformed --set {item!r}; expected KEY=VALUE, e.g. --set mu=0.5")
    return key, value


def _convert(key: str, text: str, default):
    """``text`` as the type of ``default`` (physical keys are floats; 'inf' allowed)."""
    try:
        if isinstance(default, bool):
            if text.lower() in ("1", "true", "yes", "on"):
                return True
            if text.lower() in ("0", "false", "no", "off"):
                return False
            raise ValueError
        if isinstance(default, int):
            return int(text)
        if isinstance(default, float):
            return float(text)
        return type(default)(text)
    except ValueError:
        kind = {bool: "true/false", int: "an integer", float: "a number"}.get(type(default), type(default).__name__)
        raise UserError(f"--set {key}={text}: expected {kind}") from None


def resolve_settings(study: Study, quick: bool = False, sets=()) -> dict:
    """Settings of one run: defaults < quick overrides < ``--set KEY=VALUE`` items."""
    settings = default_settings(study)
    if quick:
        settings.update(study.quick)
    for item in sets:
        key, text = parse_set(item)
        if key not in settings:
            raise UserError(f"unknown setting {key!r} for study {study.name!r}; "
                            f"known: {', '.join(sorted(settings))}")
        settings[key] = _convert(key, text, settings[key])
    return settings


def build_params(settings: dict) -> solver.Params:
    """The validated :class:`solver.Params` of the physical settings (and ``rho_over_R`` if set)."""
    from study.sweep import params_from

    return params_from(settings)


def build_axes(study: Study, settings: dict) -> list[Axis]:
    """The study's axes for these settings; invalid ones become a :class:`UserError`."""
    try:
        axes = list(study.axes(settings))
    except ValueError as exc:
        raise UserError(f"settings give invalid axes for {study.name!r}: {exc}") from None
    if len({a.name for a in axes}) != len(axes):
        raise ValueError(f"study {study.name!r} declares duplicate axis names")
    return axes


def chunk_slices(study: Study, axes: list[Axis]) -> list[tuple[slice, ...]]:
    """Slices of the outer-product grid, one tuple per chunk (C order)."""
    per_axis = []
    for i, axis in enumerate(axes):
        n = axis.values.size
        size = study.chunks.get(axis.name, DEFAULT_CHUNK if i == 0 else n)
        size = max(1, min(int(size), n))
        per_axis.append([slice(k, min(k + size, n)) for k in range(0, n, size)])
    return list(itertools.product(*per_axis))


def chunk_shape(study: Study, axes: list[Axis]) -> tuple[int, ...]:
    """Shape of a full chunk (used for netCDF chunking too)."""
    first = chunk_slices(study, axes)[0]
    return tuple(s.stop - s.start for s in first)


def _compute_chunk(study, axes, index, params, settings):
    coords = np.meshgrid(*(a.values[s] for a, s in zip(axes, index)), indexing="ij")
    out = study.compute(coords, params, settings)
    shape = coords[0].shape
    result = {}
    for var in study.variables:
        if var.name not in out:
            raise KeyError(f"study {study.name!r}: compute returned no {var.name!r}")
        result[var.name] = np.broadcast_to(np.asarray(out[var.name]), shape).astype(var.dtype)
    return result


class _Advance(Callback):
    """Advance a :class:`ProgressLine` for each finished ``chunk-*`` task."""

    def __init__(self, line: ProgressLine):
        super().__init__()
        self.line = line

    def _posttask(self, key, result, dsk, state, worker_id):
        if isinstance(key, str) and key.startswith("chunk-"):
            self.line.advance()


def evaluate(study: Study, axes: list[Axis], params, settings: dict, workers: int | None = None,
             progress: bool = False) -> dict[str, np.ndarray]:
    """Evaluate ``study.compute`` on every chunk as dask tasks; full numpy arrays per variable.

    ``workers``: threads (default: one per core). ``progress``: show chunks done/total on
    stderr once the run takes longer than about 2 s.
    """
    workers = workers or os.cpu_count() or 1
    shape = tuple(a.values.size for a in axes)
    slices = chunk_slices(study, axes)
    tasks = [dask.delayed(_compute_chunk, pure=False)(study, axes, index, params, settings,
                                                      dask_key_name=f"chunk-{k}")
             for k, index in enumerate(slices)]
    line = ProgressLine(len(tasks), study.name, enabled=progress)
    with _Advance(line):
        results = dask.compute(*tasks, scheduler="threads", num_workers=workers)
    line.close()
    arrays = {v.name: np.empty(shape, dtype=v.dtype) for v in study.variables}
    for index, chunk in zip(slices, results):
        for name, values in chunk.items():
            arrays[name][index] = values
    return arrays

