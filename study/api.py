"""rimroll's Python API for studies: ``run`` one, ``open`` a result, list the ``studies``.

``rimroll.run``, ``rimroll.open`` and ``rimroll.studies`` are these functions. ``run`` takes the
path of ``study run``: its keyword settings go as they are (Python values, no text) to
``study.settings``, which resolves and checks them by the rules of ``--set`` (a list, tuple, range
or numpy array of a sweepable setting becomes an axis of the cube); the plan carries the run's
fingerprint, and ``study.execute.run_to_file`` reuses a file of the same fingerprint, resumes the
parts of an interrupted run and refuses to overwrite a file of other inputs. Notices go through
``logging`` (logger ``"rimroll"``), lanes that did not finish ok through ``warnings``
(``rimroll.LaneStatusWarning``).
"""

from __future__ import annotations

import os
import pathlib
import tempfile
import warnings
from typing import Any

import numpy as np
import xarray as xr

from rimroll._messages import LaneStatusWarning
from rimroll.study import checks, execute, fanout, io, registry, run_notices
from rimroll.study import progress as _progress
from rimroll.study.plan import make_plan
from rimroll.study.registry import UserError, natural_order

__all__ = ["open", "run", "studies"]


def studies() -> dict[str, str]:
    """Every named study, ``{name: title}``, in natural order (``fig3 ... fig13``, then the others): as
    ``study list``, from the catalogue of rimroll's own studies without importing a studies module
    (``study.catalogue.titles``), else (a plugin's study, ``$RIMROLL_STUDY_MODULES``) from the studies' modules."""
    from rimroll.study import catalogue

    titles = catalogue.titles()
    if titles is None:
        titles = {name: registry.get(name).title for name in registry.names()}
    return {name: titles[name] for name in natural_order(titles)}


def open(path: str | os.PathLike, lazy: bool = True) -> xr.Dataset:  # noqa: A001  rimroll.open, like xr.open_*
    """Open a rimroll result file (``study run``, ``run`` with ``out``).

    ``lazy`` (default): dask-backed in the file's storage chunks, so a cube larger than memory opens
    at once; close it (or use ``with``) when done. ``lazy=False``: loaded into memory, file closed.
    Files of every rimroll version open alike; a label axis (``scene``, ``integrator``) is indexed by
    its labels, ``ds.sel(scene="slipping")``. ``UserError`` if ``path`` is not a rimroll result.
    """
    _check_path("path", path)
    _check_flag("lazy", lazy)
    return io.open_result(pathlib.Path(path), lazy=bool(lazy))


def _check_client(client: Any) -> None:
    from distributed import Client

    if not isinstance(client, Client):
        raise UserError(f"client must be a dask.distributed.Client (or use scheduler= with an address); got "
                        f"{type(client).__name__} {client!r}")


def _check_flag(key: str, value: Any) -> None:
    if not isinstance(value, (bool, np.bool_)):
        raise UserError(f"{key} must be True or False; got {value!r}")


def _check_path(key: str, value: Any) -> None:
    if not isinstance(value, (str, os.PathLike)) or not os.fspath(value):
        raise UserError(f"{key} must be a path (str or os.PathLike, not empty); got {value!r}")


def run(name: str, quick: bool = False, out: str | os.PathLike | None = None, client: Any = None, *,
        force: bool = False, workers: int | None = None, scheduler: str | None = None,
        scheduler_file: str | os.PathLike | None = None, timeout: float = fanout.DEFAULT_TIMEOUT,
        progress: bool | None = None, plot: bool = False, **settings: Any) -> xr.Dataset:
    """Run the named study ``name`` and return its result as an ``xarray.Dataset``.

    Parameters
    ----------
    name:
        a study of ``studies`` (``study list``).
    quick:
        the study's coarse settings (``study run --quick``).
    out:
        a directory: the result is ``<out>/<name>.nc``, reused when it holds this very run (same
        fingerprint), resumed from its parts when a run of the same inputs was interrupted, and
        refused (``UserError``) when it holds another run, unless ``force``; the Dataset is
        opened lazily from it. None (default): computed in a temporary directory and returned
        loaded in memory.
    client:
        a ``distributed.Client`` to compute the chunks on (a cluster of yours: dask-jobqueue,
        dask-cuda, ...); its workers must run the same rimroll (a worker with other code refuses
        the chunks). Else ``scheduler`` (an address), ``scheduler_file``, or ``workers`` local
        threads (default one per core); ``timeout`` [s] bounds every wait on a cluster.
    progress:
        show chunks done / total (a bar in a notebook, a line on stderr in a terminal); default:
        in a notebook, or when stderr is a terminal. Quiet for the first 2 s.
    plot:
        with ``out``, also draw ``<out>/<name>.png`` as ``study run`` does.
    **settings:
        the study's settings and physical parameters, as ``study run --set`` gives them but as Python
        values, handed on as they are: a number, a label, True/False, or several (a list, tuple,
        ``range`` or numpy array, e.g. ``numpy.linspace(0.5, 2, 4)``: a sweep, an outer axis of the
        cube), e.g. ``run("outcome-cube", quick=True, mu=[0.5, 1, 2], k_r=0)``,
        ``run("shot", quick=True, geometry=("paper", "regulation"))``.

    Returns
    -------
    xarray.Dataset
        the result: loaded in memory without ``out``, opened lazily from ``<out>/<name>.nc`` with it.

    Raises
    ------
    UserError
        a bad name, setting or cluster (one line, before any work), or another run in ``out``.

    Warns
    -----
    LaneStatusWarning
        when lanes of the result did not finish their integration ok (see its ``status`` variable).
    """
    study = registry.get(name)
    for key, value in (("quick", quick), ("force", force), ("plot", plot)):
        _check_flag(key, value)
    if progress is not None:
        _check_flag("progress", progress)
    if out is not None:
        _check_path("out", out)
    if scheduler_file is not None:
        _check_path("scheduler_file", scheduler_file)
    if scheduler is not None and not isinstance(scheduler, str):
        raise UserError(f"scheduler must be an address str such as 'tcp://HOST:8786', not "
                        f"{type(scheduler).__name__} {scheduler!r}")
    if isinstance(timeout, (bool, np.bool_)) or not isinstance(timeout, (int, float, np.integer, np.floating)):
        raise UserError(f"timeout must be a number of seconds, > 0 and <= 86400; got {timeout!r}")
    checks.check_workers(workers, "workers")
    if client is not None:
        _check_client(client)
    remote = bool(client is not None or scheduler or scheduler_file)
    if workers is not None and remote:
        raise UserError("workers= is for local runs; a cluster has its own workers")
    if not (0 < timeout <= 86400):
        raise UserError(f"timeout must be > 0 and <= 86400 s; got {timeout}")
    fanout.check_address(scheduler)
    plan = make_plan(study, quick, settings, local=not remote)
    command = "rimroll.run(" + ", ".join([repr(name)] + (["quick=True"] if quick else [])
                                         + [f"{k}={v!r}" for k, v in settings.items()]) + ")"
    cluster = execute.Cluster(client, workers, scheduler, os.fspath(scheduler_file) if scheduler_file else None,
                              timeout)
    shown = _progress.wanted(progress)
    if out is None:
        with tempfile.TemporaryDirectory(prefix="rimroll-") as tmp:
            try:
                outcome = execute.run_to_file(plan, tmp, command, cluster, progress=shown)
            except run_notices.RunInterrupted as stop:  # its chunks were in the temporary folder, deleted now
                raise run_notices.RunInterrupted(
                    f"{stop.args[0].split(';')[0]}; without out= nothing is kept (the run's temporary folder is "
                    "deleted): give out= to keep what a run finishes and resume it", stop.exit_status) from None
            _warn_lanes(outcome.path, f"rimroll.run({name!r})")
            return io.open_result(outcome.path)
    try:
        outcome = execute.run_to_file(plan, out, command, cluster, force=force, progress=shown)
    except UserError as exc:  # said in the command line's words (--out, --force): in this function's
        raise UserError(_api_words(str(exc))) from None
    _warn_lanes(outcome.path, str(outcome.path))
    if plot and study.plot is not None:
        with io.open_result(outcome.path, lazy=True) as ds:
            io.write_figure(study.plot(ds), outcome.path.with_suffix(".png"))
    return io.open_result(outcome.path, lazy=True)


def _api_words(message: str) -> str:
    """A refusal of the study layer in the words of :func:`run`: ``out=`` and ``force=True`` where the
    command line says ``--out`` and ``--force``."""
    return message.replace("another --out", "another out=").replace("use --force", "use force=True").replace(
        "--force resumes", "force=True resumes").replace("(with --force", "(with force=True")


def _warn_lanes(path: pathlib.Path, what: str) -> None:
    summary = run_notices.status_summary(path)
    if summary:
        warnings.warn(summary.replace(str(path), what), LaneStatusWarning, stacklevel=3)
