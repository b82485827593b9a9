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
import pathlib
import tempfile

import xarray as xr

from rimroll.study import fanout, io, reuse, runguard
from rimroll.study.assemble import assemble
from rimroll.study.dataset import global_attrs
from rimroll.study.parts import PartStore
from rimroll.study.plan import Plan
from rimroll.study.progress import ProgressLine


def file_attrs(plan: Plan, command: str, device: str | None = None) -> dict:
    """Global attributes of the file of ``plan`` made by ``command``: provenance
    (``study.dataset.global_attrs``; ``device``: the GPUs of a CUDA run) and the plan's
    ``run_fingerprint`` (``study.reuse``)."""
    attrs = global_attrs(plan.study, plan.params, plan.settings, command, tuple(a.name for a in plan.outer),
                         device=device)
    attrs[reuse.FINGERPRINT_ATTR] = plan.fingerprint
    return attrs


def produce(plan: Plan, store: PartStore, nc, command: str, *, extra_attrs=None, client=None,
            workers: int | None = None, scheduler: str | None = None,
            timeout: float = fanout.DEFAULT_TIMEOUT, progress: bool = False) -> fanout.RunStats:
    """Write the result of ``plan`` to ``nc`` (atomically); call with ``store``'s lock held.

    Parts of this study's other inputs are deleted (no live run owns them), intact parts of this
    plan are kept (a resumed run), the missing chunks are computed on ``client`` (else on a
    cluster opened here: ``workers`` local threads or the one at ``scheduler``), the file is
    assembled with :func:`file_attrs` plus ``extra_attrs``, and the parts are removed. A plan on
    the CUDA backend runs one GPU per worker (``fanout.client(gpu=True)``), and its file names the
    workers' devices.
    """
    store.sweep_stale()
    done = store.valid(plan.n_chunks, plan.expected)
    todo = [k for k in range(plan.n_chunks) if k not in done]
    runguard.announce(plan, len(todo))
    line = ProgressLine(plan.n_chunks, plan.study.name, resumed=len(done), enabled=progress)
    gpu = plan.backend == "cuda"
    opened = (contextlib.nullcontext(client) if client is not None
              else fanout.client(workers, scheduler, timeout, gpu=gpu))
    with opened as c:
        stats = fanout.run(plan, store, todo, c, line, timeout=timeout)
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
