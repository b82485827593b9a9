"""The one way a plan becomes a result: resume intact parts, fan the rest out, assemble, tidy up.

``study run``, ``study reference --build`` and the in-memory :func:`compute` (the reference
regression tests, tests of a study's numbers) all go through :func:`produce`: chunks as
dask.distributed tasks (``study.fanout``), each streamed to its part file (``study.parts``),
then one netCDF assembled region by region with the study's derived variables
(``study.assemble``) and the parts deleted. So a number in any file, or in any test of a
study, was made by the same code.
"""

from __future__ import annotations

import contextlib
import dataclasses
import logging
import pathlib
import tempfile
from typing import Any

import xarray as xr

from rimroll.study import existing_result, fanout, io, run_notices
from rimroll.study.assemble import assemble
from rimroll.study.dataset import global_attrs
from rimroll.study.parts import PartStore
from rimroll.study.plan import Plan
from rimroll.study.progress import ProgressLine
from rimroll.study.registry import UserError

log = logging.getLogger(__name__)


def file_attrs(plan: Plan, command: str, device: str | None = None) -> dict:
    """Global attributes of the file of ``plan`` made by ``command``: provenance
    (``study.dataset.global_attrs``; ``device``: the GPUs of a CUDA run) and the plan's
    ``run_fingerprint`` (``study.existing_result``)."""
    attrs = global_attrs(plan.study, plan.params, plan.settings, command, tuple(a.name for a in plan.outer),
                         device=device)
    attrs[existing_result.FINGERPRINT_ATTR] = plan.fingerprint
    return attrs


@dataclasses.dataclass(frozen=True)
class Cluster:
    """Where the chunks of a run are computed: an existing dask ``client``, else a cluster opened for
    the run: the one at ``scheduler`` or named by ``scheduler_file``, or ``workers`` local threads.
    ``timeout`` bounds every wait on a cluster (``study run --timeout``)."""

    client: Any = None
    workers: int | None = None
    scheduler: str | None = None
    scheduler_file: str | None = None
    timeout: float = fanout.DEFAULT_TIMEOUT

    @property
    def remote(self) -> bool:
        return bool(self.client is not None or self.scheduler or self.scheduler_file)

    def open(self, gpu: bool):
        if self.client is not None:
            return contextlib.nullcontext(self.client)
        return fanout.client(self.workers, self.scheduler, self.timeout, gpu=gpu, scheduler_file=self.scheduler_file)


def produce(plan: Plan, store: PartStore, nc, command: str, *, extra_attrs=None, client=None,
            workers: int | None = None, scheduler: str | None = None,
            timeout: float = fanout.DEFAULT_TIMEOUT, progress: bool = False,
            cluster: Cluster | None = None) -> fanout.RunStats:
    """Write the result of ``plan`` to ``nc`` (atomically); call with ``store``'s lock held.

    Parts of this study's other inputs are kept and named in a notice (an interrupted run of other
    settings resumes from them), intact parts of this plan are kept (a resumed run), the missing
    chunks are computed on ``cluster`` (or on ``client``, else on a cluster opened here: ``workers``
    local threads or the one at ``scheduler``), the file is assembled with :func:`file_attrs` plus
    ``extra_attrs``, and the parts are removed. A plan on the CUDA backend runs one GPU per worker
    (``fanout.client(gpu=True)``), and its file names the workers' devices. The link to the
    cluster's dashboard is a notice (logging, INFO) for a cluster that is not local threads, and
    for a local run long enough to announce its plan.
    """
    cluster = cluster or Cluster(client, workers, scheduler, None, timeout)
    _name_others(store)
    done = store.valid(plan.n_chunks, plan.expected)
    todo = [k for k in range(plan.n_chunks) if k not in done]
    run_notices.announce(plan, len(todo))
    line = ProgressLine(plan.n_chunks, plan.study.name, resumed=len(done), enabled=progress)
    gpu = plan.backend == "cuda"
    with cluster.open(gpu) as c:
        link = fanout.dashboard(c) if todo and (cluster.remote or len(todo) >= run_notices.ANNOUNCE_CHUNKS) else None
        if link:
            log.info("%s: dashboard of the cluster at %s", plan.study.name, link)
        stats = fanout.run(plan, store, todo, c, line, timeout=cluster.timeout)
        device = fanout.devices(c) if gpu else None
    assemble(plan, store, nc, {**file_attrs(plan, command, device), **(extra_attrs or {})})
    store.remove()
    return stats


def compute(plan: Plan, command: str, workers: int | None = None) -> xr.Dataset:
    """The result of ``plan`` loaded in memory: :func:`produce` into a temporary directory, read
    back and deleted. ``command`` is recorded in ``history``."""
    with tempfile.TemporaryDirectory(prefix="rimroll-") as tmp:
        nc = pathlib.Path(tmp) / f"{plan.study.name}.nc"
        store = PartStore(tmp, plan.study.name, plan.fingerprint)
        with store.lock():
            produce(plan, store, nc, command, workers=workers)
        return io.open_result(nc)


@dataclasses.dataclass(frozen=True)
class Outcome:
    """What :func:`run_to_file` did: the file, and the run's statistics (None: the file already held
    this very run, and was reused)."""

    path: pathlib.Path
    stats: fanout.RunStats | None


def run_to_file(plan: Plan, out, command: str, cluster: Cluster, *, force: bool = False,
                progress: bool = False) -> Outcome:
    """``study run`` and :func:`rimroll.run`: ``<out>/<name>.nc`` of ``plan``, by the fingerprint rule.

    A file of this plan's fingerprint is reused (``study.existing_result``); one of other inputs is a
    :class:`UserError` unless ``force``; an unreadable one is recomputed. Otherwise, holding the
    output's lock (``study.parts``; a second run into the same file is refused), the parts of an
    interrupted run of the same inputs are resumed and the rest computed (:func:`produce`).
    """
    out = pathlib.Path(out)
    run_notices.check_out(out)
    run_notices.check_targets(out, plan.study.name, plan.study.plot is not None)
    run_notices.check_estimate(plan)
    nc = out / f"{plan.study.name}.nc"
    request = file_attrs(plan, command)
    sizes = {a.name: a.values.size for a in plan.axes}
    store = PartStore(out, plan.study.name, plan.fingerprint)
    if not force and _reusable(plan, nc, request, sizes, store):
        _tidy(store)
        return Outcome(nc, None)
    with run_notices.saved_on_stop(store, plan), store.lock():  # a full disk already at the lock: one line
        if not force and _reusable(plan, nc, request, sizes, store, quiet=True):
            return Outcome(nc, None)  # a run that held the lock just finished it
        stats = produce(plan, store, nc, command, progress=progress, cluster=cluster)
    return Outcome(nc, stats)


def _reusable(plan: Plan, nc: pathlib.Path, request: dict, sizes: dict, store: PartStore,
              quiet: bool = False) -> bool:
    """True if ``nc`` is this very run; False if it must be (re)computed; UserError if it holds
    another run (the fingerprint rule of ``study.existing_result``), saying so when chunks of this very run,
    interrupted, wait in the parts folder (--force resumes them)."""
    found = existing_result.inspect(nc, plan.fingerprint, request, sizes)
    if found.state == "different":
        saved = store.count()
        resume = (f"; {saved} chunk{'' if saved == 1 else 's'} of this very run, interrupted, wait in {store.dir}: "
                  "--force resumes them" if saved else "")
        raise UserError(f"{nc} holds another run of {plan.study.name} ({found.detail}){resume}; use --force to "
                        "replace it (it is kept until the new file is complete), or another --out")
    if found.state == "unreadable" and not quiet:
        log.warning("%s is not a readable result (%s); recomputing it", nc, found.detail)
    return found.state == "same"


def _tidy(store: PartStore) -> None:
    """The result is complete: parts of this very run left by a run killed during its cleanup belong
    to no live run; delete them unless a run holds the lock. Parts of other inputs are kept (named)."""
    if not store.root.is_dir():
        return
    try:
        with store.lock():
            _name_others(store)
            store.remove()
    except UserError:  # another run of this study into this --out is live: leave its parts alone
        pass


def _name_others(store: PartStore) -> None:
    """A notice for each parts folder of this study's other inputs: kept, and how to use or drop it."""
    for folder, n in store.others():
        log.info("%s holds %d chunk%s saved by an interrupted run of %s with other settings: kept; rerun "
                 "that command to resume it (with --force once %s holds this run's result), or delete the folder",
                 folder, n, "" if n == 1 else "s", store.study, store.target.name)
