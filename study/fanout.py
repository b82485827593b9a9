"""Run the chunks of a plan as dask.distributed tasks and stream each result to its part file.

One code path for both cases: locally an in-process cluster of threads (the kernels release
the GIL; ``--workers N`` threads, default one per core), or an existing cluster reached with
``--scheduler ADDRESS``. Tasks are :func:`study.plan.compute_chunk` on a picklable
:class:`study.plan.ChunkJob`. At most a small window of tasks is in flight; each result is
written to disk as it completes (``as_completed``) and dropped, so memory holds a few chunks
whatever the size of the cube.
"""

from __future__ import annotations

import contextlib
import dataclasses
import logging
import os
import time
import uuid

import dask

from study.parts import PartStore
from study.plan import Plan, compute_chunk
from study.progress import ProgressLine
from study.registry import UserError


@dataclasses.dataclass
class RunStats:
    total: int
    resumed: int
    computed: int = 0
    compute_s: float = 0.0  # sum over chunks of the time inside compute
    wall_s: float = 0.0  # from the first submit to the last part written


def timed_chunk(job):
    """``compute_chunk`` plus its duration [s] (what the overhead figure compares against)."""
    t0 = time.perf_counter()
    arrays = compute_chunk(job)
    return job.k, arrays, time.perf_counter() - t0


@contextlib.contextmanager
def client(workers: int | None = None, scheduler: str | None = None):
    """A dask.distributed Client: the cluster at ``scheduler``, else threads in this process."""
    from distributed import Client, LocalCluster

    for name in ("distributed", "distributed.scheduler", "distributed.nanny"):
        logging.getLogger(name).setLevel(logging.ERROR)
    logging.getLogger("distributed.worker").setLevel(logging.CRITICAL)  # the client re-raises task errors
    if scheduler:
        try:
            c = Client(scheduler, timeout=dask.config.get("distributed.comm.timeouts.connect"))
        except (OSError, TimeoutError, ValueError) as exc:
            raise UserError(f"cannot connect to the dask scheduler at {scheduler}: {exc}") from None
        with c:
            yield c
        return
    threads = workers or os.cpu_count() or 1
    # dashboard on a free port: the default 8787 may be taken (a warning per run otherwise)
    with LocalCluster(n_workers=1, threads_per_worker=threads, processes=False, dashboard_address=":0",
                      memory_limit=0) as cluster, Client(cluster) as c:
        yield c


def run(plan: Plan, store: PartStore, todo: list[int], c, progress: ProgressLine) -> RunStats:
    """Compute the chunks ``todo`` on client ``c``, writing each part as it finishes."""
    from distributed import as_completed

    stats = RunStats(total=plan.n_chunks, resumed=plan.n_chunks - len(todo))
    if not todo:
        return stats
    threads = sum(c.nthreads().values()) or 1
    window = 2 * threads + 2
    pending = iter(todo)
    token = uuid.uuid4().hex[:8]  # keys unique per run, even on a long-lived shared scheduler

    def submit():
        k = next(pending, None)
        if k is None:
            return None
        return c.submit(timed_chunk, plan.job(k), key=f"chunk-{plan.fingerprint}-{k}-{token}", pure=False)

    t0 = time.perf_counter()
    inflight = {f for f in (submit() for _ in range(window)) if f is not None}
    queue = as_completed(list(inflight))
    try:
        for future in queue:
            inflight.discard(future)
            k, arrays, seconds = future.result()
            future.release()
            store.save(k, arrays)
            del arrays
            stats.computed += 1
            stats.compute_s += seconds
            progress.advance()
            nxt = submit()
            if nxt is not None:
                inflight.add(nxt)
                queue.add(nxt)
    except BaseException:
        for f in inflight:
            f.cancel()
        raise
    finally:
        progress.close()
    stats.wall_s = time.perf_counter() - t0
    return stats
