"""Run the chunks of a plan as dask.distributed tasks and stream each result to its part file.

One code path for both cases: locally an in-process cluster of threads (the kernels release
the GIL; ``--workers N`` threads, default one per core), or an existing cluster reached with
``--scheduler ADDRESS`` or ``--scheduler-file PATH`` (or a client passed to ``rimroll.run``).
Every connection, the probe of the address included, uses dask's ``Security`` from the dask
configuration (:func:`security`), so a ``tls://`` scheduler works as a ``tcp://`` one. Tasks are
:func:`study.plan.compute_chunk` on a picklable :class:`study.plan.ChunkJob`, which carries the
client's code digest: a worker running other code refuses it (``study.plan.check_digest``). At
most a small window of tasks is in flight; each result is written to disk as it completes and
dropped, so memory holds a few chunks whatever the size of the cube.

With the CUDA backend (a study's ``backend`` setting) each worker process uses one GPU: locally
one single-threaded worker per visible GPU (processes when there are several), on a
``--scheduler`` cluster whatever workers it has; ``study.gpu_workers`` picks each worker's device
(rimroll's local workers by their number, a dask-cuda worker device 0 of the devices it was given).

Every wait is bounded by ``timeout`` seconds (``study run --timeout``): a ``--scheduler`` address
must answer dask's identity call in that time (an HTTP server, a socket that never answers or
an unreachable host give one line; a client-side TLS mistake is said as such first, :func:`tls_problem`),
must have a worker within it, and a run whose cluster has had no live worker for that long (one the
scheduler has heard from, :class:`Liveness`; a scheduler that does not answer has none) stops with
the count of saved chunks (a rerun resumes).
"""

from __future__ import annotations

import contextlib
import dataclasses
import logging
import os
import sys
import time
import uuid

from rimroll.study.checks import DEFAULT_TIMEOUT  # [s] bound on waiting for a scheduler and for its workers
from rimroll.study.parts import PartStore
from rimroll.study.plan import Plan, compute_chunk
from rimroll.study.progress import ProgressLine
from rimroll.study.registry import UserError
from rimroll.study.stopping import TEARDOWN_LOGGERS, silence
from rimroll.study.stopping import unsilence as restore

POLL = 0.5  # [s] how often a run checks that its cluster still has workers


def check_address(scheduler: str | None) -> None:
    """A ``--scheduler`` address of the form ``[protocol://]host:port`` (checked without connecting)."""
    if not scheduler:
        return
    from distributed.comm import parse_address

    try:
        protocol, loc = parse_address(scheduler)
        host, _, port = loc.rpartition(":")
        ok = protocol in ("tcp", "tls", "ucx", "ws", "wss") and host and 0 < int(port) < 65536
    except (ValueError, TypeError):
        ok = False
    if not ok:
        raise UserError(f"--scheduler {scheduler!r} is not an address of the form tcp://HOST:PORT (or tls://...)")


def security():
    """dask's :class:`distributed.security.Security` of the dask configuration (``distributed.comm.tls``:
    CA file, client certificate and key, ``require-encryption``), which every connection of a run uses."""
    from distributed.security import Security

    return Security()


def tls_problem(address: str) -> str | None:
    """What in this client's TLS settings (dask's configuration ``distributed.comm.tls`` and
    ``distributed.comm.require-encryption``, :func:`security`) keeps it from connecting to ``address``,
    checked without connecting; None when nothing does. A client-side mistake is said as such, not
    taken for a server that does not speak dask."""
    import ssl

    from distributed.comm import parse_address

    sec = security()
    protocol = parse_address(address)[0]
    if protocol not in ("tls", "wss"):
        if sec.require_encryption:
            return (f"the dask configuration of this client requires encryption (distributed.comm.require-encryption) "
                    f"and {address} is not encrypted: use the scheduler's tls:// address, or unset that setting")
        return None
    settings = {"distributed.comm.tls.ca-file": sec.tls_ca_file,
                "distributed.comm.tls.client.cert": sec.tls_client_cert,
                "distributed.comm.tls.client.key": sec.tls_client_key}
    missing = [key for key, value in list(settings.items())[:2] if not value]
    if missing:
        return (f"{address} needs this client's TLS settings and the dask configuration has no "
                f"{' and no '.join(missing)} "
                "(set them, and distributed.comm.tls.client.key when the key is not in the certificate's file; e.g. "
                "DASK_DISTRIBUTED__COMM__TLS__CA_FILE=ca.pem)")
    for key, value in settings.items():
        if value and not os.path.isfile(value):
            return f"the file {value} of this client's TLS setting {key} does not exist"
    try:
        sec.get_connection_args("client")
    except (ssl.SSLError, OSError, ValueError) as exc:
        given = ", ".join(f"{key.rsplit('.', 2)[-2] + '.' if 'client' in key else ''}{key.rsplit('.', 1)[-1]} {value}"
                          for key, value in settings.items() if value)
        hint = "" if sec.tls_client_key else "; a certificate without its key needs distributed.comm.tls.client.key"
        return (f"this client's TLS settings ({given}) cannot be loaded: {' '.join(str(exc).split())} (not PEM "
                f"certificates and key?){hint}")
    return None


def scheduler_address(path, timeout: float) -> str:
    """The address in the scheduler file ``path`` (``dask scheduler --scheduler-file``, dask-jobqueue,
    dask-mpi), waiting up to ``timeout`` s for the file to appear; UserError otherwise."""
    import json
    import pathlib

    if not isinstance(path, (str, os.PathLike)) or not str(path):
        raise UserError(f"scheduler_file must be the path of a dask scheduler file (a str or os.PathLike), "
                        f"not {type(path).__name__} {path!r}")
    file = pathlib.Path(path)
    deadline = time.monotonic() + timeout
    while True:
        try:
            address = json.loads(file.read_text())["address"]
            if isinstance(address, str) and address:
                return address
            raise ValueError("no address")
        except FileNotFoundError:
            if time.monotonic() > deadline:
                raise UserError(f"no scheduler file at {path} after {timeout:g} s") from None
        except (OSError, ValueError, KeyError, TypeError) as exc:
            if time.monotonic() > deadline:
                raise UserError(f"--scheduler-file {path} is not a dask scheduler file ({exc})") from None
        time.sleep(POLL)


def _identity(address: str, timeout: float) -> dict:
    """The scheduler's answer to dask's ``identity`` call, all of it within ``timeout`` seconds, over a
    connection made with the configured :func:`security` (TLS for ``tls://``)."""
    import asyncio

    from distributed.comm import connect

    args = security().get_connection_args("client")

    async def ask():
        comm = await connect(address, timeout=timeout, **args)
        try:
            await comm.write({"op": "identity"})
            return await comm.read()
        finally:
            comm.abort()

    async def bounded():
        return await asyncio.wait_for(ask(), timeout)

    return asyncio.run(bounded())


def probe_scheduler(address: str, timeout: float) -> None:
    """:class:`UserError` unless a dask scheduler answers at ``address`` within ``timeout`` s."""
    try:
        answer = _identity(address, timeout)
    except (TimeoutError, OSError) as exc:
        why = "no answer" if isinstance(exc, TimeoutError) or not str(exc) else " ".join(str(exc).split())
        raise UserError(f"cannot connect to the dask scheduler at {address} within {timeout:g} s: {why}") from None
    except Exception as exc:  # noqa: BLE001  garbage from something else (an HTTP server: a huge 'frame')
        raise UserError(f"{address} is not a dask scheduler (its answer is not dask's protocol: "
                        f"{type(exc).__name__})") from None
    if not isinstance(answer, dict) or answer.get("type") != "Scheduler":
        raise UserError(f"{address} is not a dask scheduler (identity: {str(answer)[:80]})")


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


def gpu_workers(workers: int | None) -> int:
    """Local GPU workers of a CUDA run: one per visible device, at most ``workers`` (UserError if none)."""
    from rimroll.solver.engine import backends

    n = backends.cuda_device_count()
    if n == 0:
        try:
            backends.cuda_device()
        except backends.BackendUnavailable as exc:
            raise UserError(str(exc)) from None
    return max(1, min(n, workers or n))


def devices(c) -> str:
    """The CUDA devices the workers of client ``c`` compute on, e.g. 'NVIDIA H100 80GB HBM3' (distinct
    names joined by '; ')."""
    from rimroll.solver.engine import backends

    names = sorted(set(c.run(backends.worker_device).values()))
    return "; ".join(names)


@contextlib.contextmanager
def client(workers: int | None = None, scheduler: str | None = None, timeout: float = DEFAULT_TIMEOUT,
           gpu: bool = False, scheduler_file: str | None = None):
    """A dask.distributed Client: the cluster at ``scheduler`` or named by ``scheduler_file`` (which
    must answer and have a worker within ``timeout`` s; connections use the configured
    :func:`security`), else threads in this process. ``gpu``: the run uses the CUDA backend, one
    GPU per worker (``study.gpu_workers.OneGPUPerWorker``; locally one worker per GPU)."""
    from distributed import Client, LocalCluster

    from rimroll.study.gpu_workers import OneGPUPerWorker

    for name in ("distributed", "distributed.scheduler", "distributed.nanny"):
        logging.getLogger(name).setLevel(logging.ERROR)
    logging.getLogger("distributed.worker").setLevel(logging.CRITICAL)  # the client re-raises task errors
    for name in ("distributed.client", "distributed.utils"):  # a lost scheduler: our one line says it (run)
        logging.getLogger(name).setLevel(logging.CRITICAL)
    if scheduler_file:
        scheduler = scheduler_address(scheduler_file, timeout)
    if scheduler:
        check_address(scheduler)
        if problem := tls_problem(scheduler):
            raise UserError(f"cannot connect to the dask scheduler at {scheduler}: {problem}")
        probe_scheduler(scheduler, timeout)
        try:
            c = Client(scheduler, timeout=timeout, security=security())
        except (OSError, TimeoutError, ValueError) as exc:
            raise UserError(f"cannot connect to the dask scheduler at {scheduler}: {exc}") from None
        with c:
            try:
                c.wait_for_workers(1, timeout=timeout)
            except (TimeoutError, OSError):
                raise UserError(f"no workers at {scheduler} after {timeout:g} s") from None
            if gpu:
                c.register_plugin(OneGPUPerWorker())
            yield c
        return
    # the dashboard on a free port of the loopback address: 8787 may be taken, and a run's
    # dashboard is for the one who started it
    local = {"dashboard_address": "127.0.0.1:0", "memory_limit": 0}
    if gpu:
        n = gpu_workers(workers)
        where = {"processes": True, "host": "127.0.0.1"} if n > 1 else {"processes": False}
        with LocalCluster(n_workers=n, threads_per_worker=1, **where, **local) as cluster, Client(cluster) as c:
            c.register_plugin(OneGPUPerWorker(local=True))
            yield c
        return
    threads = workers or os.cpu_count() or 1
    silenced = {}
    try:
        with LocalCluster(n_workers=1, threads_per_worker=threads, processes=False, **local) as cluster, \
                Client(cluster) as c:
            try:
                yield c
            except BaseException:
                silenced = silence(TEARDOWN_LOGGERS)
                raise
    finally:
        restore(silenced)


def dashboard(c) -> str | None:
    """The link to the dashboard of client ``c``'s scheduler, or None when it has none."""
    try:
        return c.dashboard_link or None
    except Exception:  # noqa: BLE001  a scheduler without an HTTP server
        return None


class Liveness:
    """The workers of a cluster that are alive: known to its scheduler, and heard from within ``timeout``
    seconds (each worker's heartbeat moves its ``last_seen`` on the scheduler; a worker whose process is
    gone while its connection lingers, or that is frozen, stops moving it). Every question to the
    scheduler is bounded (``ASK_S``): a scheduler that does not answer has no live worker either."""

    ASK_S = 5.0  # [s] bound on one question to the scheduler

    def __init__(self, timeout: float):
        self.timeout = timeout
        self.heard: dict[str, tuple[float, float]] = {}  # worker -> (its last_seen, when it last moved)
        self.answered = True  # whether the scheduler answered the last question

    def threads(self, c) -> dict[str, int]:
        """The threads of each live worker (``{}`` when none, or the scheduler does not answer)."""
        try:
            info = c.sync(c.scheduler.identity, n_workers=-1, callback_timeout=min(self.ASK_S, self.timeout))
            workers = info["workers"]
        except Exception:  # noqa: BLE001  a scheduler gone, frozen or closing: no live worker
            self.answered = False
            return {}
        self.answered = True
        now = time.monotonic()
        live = {}
        for address, worker in workers.items():
            seen = worker.get("last_seen")
            last, moved = self.heard.get(address, (None, now))
            if seen != last:
                moved = now
            self.heard[address] = (seen, moved)
            if now - moved <= self.timeout:
                live[address] = int(worker.get("nthreads") or 1)
        return live


class Fetches:
    """The results of a run's chunks, each fetched as soon as its task is submitted by a task of its own on the
    client's event loop (``Client.gather(future, asynchronous=True)`` through ``asyncio.run_coroutine_threadsafe``),
    which nothing cancels; the run's thread waits on them with a bound (:meth:`done`).

    Never ``Future.result(timeout=...)``: when its bound passes it cancels its gather, and distributed (2026.8,
    dask/distributed#8514) shares a pending gather between callers (``Client._gather_future``): one cancelled in
    the moment before it starts stays the client's pending gather, and every later gather of that client fails
    with asyncio's CancelledError, which ``Client.sync`` turns into ``UnboundLocalError``. A fetch or a future
    that is cancelled all the same (by a user's client, a scheduler) is fetched again, or its chunk computed
    again, at most ``RETRIES`` times (:meth:`retry`)."""

    RETRIES = 2  # cancellations of one chunk's fetch or future that a run takes before it stops

    def __init__(self, c, submit):
        self.c = c
        self.submit = submit  # (k, attempt) -> the dask Future computing chunk k
        self.pending = {}  # a fetch (concurrent.futures.Future) -> (k, its dask Future)
        self.cancelled = {}  # k -> how many times chunk k's fetch or future was cancelled

    def start(self, k: int) -> None:
        """Submit chunk ``k`` and start fetching its result."""
        self._fetch(k, self.submit(k, self.cancelled.get(k, 0)))

    def _fetch(self, k: int, future) -> None:
        import asyncio

        fetch = asyncio.run_coroutine_threadsafe(self.c.gather(future, asynchronous=True), self.c.loop.asyncio_loop)
        self.pending[fetch] = (k, future)

    def done(self, timeout: float) -> list:
        """The fetches that have ended, waiting up to ``timeout`` s for one: ``(fetch, k, dask future)`` each."""
        from concurrent.futures import FIRST_COMPLETED, wait

        ended = wait(list(self.pending), timeout=timeout, return_when=FIRST_COMPLETED).done
        return [(fetch, *self.pending.pop(fetch)) for fetch in ended]

    def retry(self, k: int, future) -> bool:
        """Chunk ``k``'s fetch or future was cancelled: fetch it again (the future finished: only the fetch was
        cancelled) or compute it again under a new key; False when that has happened more than ``RETRIES`` times."""
        self.cancelled[k] = self.cancelled.get(k, 0) + 1
        if self.cancelled[k] > self.RETRIES:
            return False
        if future.status == "finished":
            self._fetch(k, future)
        else:
            future.release()
            self.start(k)
        return True

    def cancel(self) -> None:
        """Cancel the tasks of the chunks not fetched yet (their fetches then end by themselves)."""
        for _, future in self.pending.values():
            future.cancel()


def cancelled(exc: BaseException, future) -> bool:
    """Whether a chunk's fetch ended with ``exc`` because it or its future was cancelled: a cancelled
    future, a cancelled fetch, or the ``UnboundLocalError`` that ``Client.sync`` makes of asyncio's
    CancelledError (:class:`Fetches`); not an error of the chunk's own computation."""
    import asyncio
    from concurrent.futures import CancelledError

    return isinstance(exc, (CancelledError, asyncio.CancelledError, UnboundLocalError)) and future.status != "error"


def run(plan: Plan, store: PartStore, todo: list[int], c, progress: ProgressLine,
        timeout: float = DEFAULT_TIMEOUT) -> RunStats:
    """Compute the chunks ``todo`` on client ``c``, writing each part as it finishes.

    :class:`UserError` (after cancelling what is in flight) when the cluster has had no worker
    for ``timeout`` s, a chunk's worker died too often (``KilledWorker``), or a chunk was
    cancelled more than ``Fetches.RETRIES`` times."""
    from distributed.comm.core import CommClosedError
    from distributed.scheduler import KilledWorker

    from rimroll.study import run_notices

    stats = RunStats(total=plan.n_chunks, resumed=plan.n_chunks - len(todo))
    if not todo:
        return stats
    _drop_all_exit()
    liveness = Liveness(timeout)
    threads = sum(liveness.threads(c).values()) or 1
    window = 2 * threads + 2
    pending = iter(todo)
    token = uuid.uuid4().hex[:8]  # keys unique per run, even on a long-lived shared scheduler

    def submit(k: int, attempt: int):
        key = f"chunk-{plan.fingerprint}-{k}-{token}" + (f"-{attempt}" if attempt else "")
        return c.submit(timed_chunk, plan.job(k), key=key, pure=False)

    def lost(why: str, what: str = "worker") -> UserError:
        return UserError(f"{what} lost ({why}); {store.count()} of {plan.n_chunks} chunks saved, "
                         "rerun the same command to resume")

    def no_worker() -> UserError:
        where = _scheduler_of(c)
        if not liveness.answered:
            return lost(f"the scheduler{where} has not answered for {timeout:g} s", "scheduler")
        return lost(f"no live worker at the scheduler{where} for {timeout:g} s: start workers there (dask worker "
                    "SCHEDULER_ADDRESS) or check why they died")

    t0 = time.perf_counter()
    fetches = Fetches(c, submit)
    for k in (next(pending, None) for _ in range(window)):
        if k is not None:
            fetches.start(k)
    no_worker_since = None
    estimated = False
    seconds_of = []  # seconds of the chunks finished before the estimate, in the order they finished
    quiet_since, beat = t0, run_notices.next_heartbeat(0.0)  # a "working" notice is due when nothing ends for beat s
    try:
        while fetches.pending:
            saved = 0
            for fetch, k, future in fetches.done(POLL):
                try:
                    k, arrays, seconds = fetch.result()
                except KilledWorker as exc:
                    raise lost(type(exc).__name__) from None
                except ArithmeticError as exc:  # settings whose numbers leave floating point (j=1e308)
                    raise UserError(f"{plan.study.name}: a chunk's computation failed with {type(exc).__name__} "
                                    f"({' '.join(str(exc).split())}): the settings give numbers beyond floating "
                                    f"point; {store.count()} of {plan.n_chunks} chunks saved") from None
                except BaseException as exc:
                    if not cancelled(exc, future):
                        raise
                    if getattr(exc, "reason", None) == "scheduler-connection-lost" or c.status != "running":
                        raise lost("the client lost its connection", "scheduler") from None
                    if not fetches.retry(k, future):
                        raise lost(f"chunk {k} was cancelled {fetches.cancelled[k]} times: "
                                   f"{type(exc).__name__} {' '.join(str(exc).split())}".strip(), "chunk") from None
                    continue
                future.release()
                store.save(k, arrays)
                del arrays
                saved += 1
                stats.computed += 1
                stats.compute_s += seconds
                progress.advance()
                nxt = next(pending, None)
                if nxt is not None:
                    fetches.start(nxt)
                if not estimated:
                    seconds_of.append(seconds)
            now = time.perf_counter()
            if saved:
                quiet_since, beat = now, run_notices.next_heartbeat(0.0)
                no_worker_since = None
            elif now - quiet_since >= beat:
                if not progress.shown:  # a progress line on a terminal says it already
                    run_notices.heartbeat(plan, stats.computed, len(todo), now - t0)
                beat = run_notices.next_heartbeat(now - quiet_since)
            if not saved:
                if liveness.threads(c):
                    no_worker_since = None
                elif no_worker_since is None:
                    no_worker_since = time.monotonic()
                elif time.monotonic() - no_worker_since > timeout:
                    raise no_worker()
                continue
            if not estimated:
                per_chunk = run_notices.seconds_per_chunk(seconds_of, threads, len(todo))
                if per_chunk is not None:
                    estimated = True
                    run_notices.estimate(plan, per_chunk, len(todo) - stats.computed, threads)
    except CommClosedError:
        raise lost("its connection closed", "scheduler") from None
    except BaseException:
        fetches.cancel()
        _stop_compiles()
        raise
    finally:
        progress.close()
    stats.wall_s = time.perf_counter() - t0
    return stats


class _AllExitFilter(logging.Filter):
    """Drops asyncio's "Task exception was never retrieved ... exception=AllExit()": the leftover of a
    bounded ``Future.result(timeout=...)`` that timed out (AllExit is dask's internal sentinel)."""

    def filter(self, record: logging.LogRecord) -> bool:
        return "exception=AllExit()" not in record.getMessage()


def _drop_all_exit() -> None:
    """Install :class:`_AllExitFilter` on the ``asyncio`` logger, once per process."""
    logger = logging.getLogger("asyncio")
    if not any(isinstance(f, _AllExitFilter) for f in logger.filters):
        logger.addFilter(_AllExitFilter())


def _scheduler_of(c) -> str:
    """`` ADDRESS`` of client ``c``'s scheduler, for messages ('' when unknown)."""
    try:
        address = c.scheduler.address
    except Exception:  # noqa: BLE001
        return ""
    return f" {address}" if address else ""


def _stop_compiles() -> None:
    """A run stopped while its threads wait for kernels compiled in child processes: stop those now, not
    after the compile (``solver.engine.compiling.stop_all``; nothing when no kernel was compiled here)."""
    compiling = sys.modules.get("rimroll.solver.engine.compiling")
    if compiling is not None:
        compiling.stop_all()
