"""What ``study run`` checks before the work and says after it: the output directory, the plan of
a long run, a run stopped by Ctrl-C or a full disk (one line: how much was saved), and lanes
whose integration status is not ok.
"""

from __future__ import annotations

import contextlib
import errno
import logging
import os
import pathlib
import tempfile

import numpy as np

from rimroll.study import io, registry
from rimroll.study.parts import PARTS
from rimroll.study.registry import UserError

log = logging.getLogger(__name__)

ANNOUNCE_CHUNKS = 100  # runs of at least this many chunks print their plan before starting
ANNOUNCE_SECONDS = 5.0  # and runs the study's cost model puts at this many seconds of one core or more
MAX_CORE_SECONDS = 365 * 86400.0  # a run the cost model puts above a year of one core is refused
HEARTBEATS = (2.0, 10.0, 30.0, 60.0)  # [s] "working" notices while no chunk finishes; then every minute


class RunStopped(UserError):
    """A run stopped before its end by a failed write (disk full); ``exit_status`` for the command line."""

    def __init__(self, message: str, exit_status: int = 2):
        super().__init__(message)
        self.exit_status = exit_status


class RunInterrupted(KeyboardInterrupt):
    """A run stopped by Ctrl-C (exit status 130) or SIGTERM (143): a KeyboardInterrupt still (an
    ``except ValueError`` around :func:`rimroll.run` does not swallow it), its message saying what was
    saved; ``exit_status`` for the command line."""

    def __init__(self, message: str, exit_status: int = 130):
        super().__init__(message)
        self.exit_status = exit_status


def check_out(out: pathlib.Path) -> None:
    """``--out`` must be a directory this user can create and write; :class:`UserError` otherwise."""
    problem = io.name_problem(out)
    if problem:
        raise UserError(f"cannot write into --out {out}: {problem}")
    if out.exists() and not out.is_dir():
        raise UserError(f"--out {out} exists and is not a directory")
    try:
        out.mkdir(parents=True, exist_ok=True)
        fd, probe = tempfile.mkstemp(prefix=".write-test-", dir=out)
        os.close(fd)
        os.unlink(probe)
    except OSError as exc:
        raise UserError(f"cannot write into --out {out}: {exc.strerror or exc}") from None


def check_targets(out: pathlib.Path, name: str, figure: bool) -> None:
    """Every path a run of study ``name`` writes into ``out`` (``NAME.nc``, ``NAME.png`` when the study
    has a ``figure``, the parts folder ``.parts`` and its lock ``.parts/NAME.lock``), checked before
    any work: one line naming the path and what is in the way (:func:`rimroll.study.io.check_target`)."""
    io.check_target(out / f"{name}.nc", "the result")
    if figure:
        io.check_target(out / f"{name}.png", "the figure")
    parts = out / PARTS
    if parts.exists() and not parts.is_dir():
        raise UserError(f"cannot write the parts folder {parts}: a file is in the way (remove it)")
    io.check_target(parts / f"{name}.lock", "the lock")


def _saved(store, plan) -> str:
    n = store.count()
    where = f" in {store.dir}" if n else ""
    return f"{n} of {plan.n_chunks} chunks saved{where}"


@contextlib.contextmanager
def saved_on_stop(store, plan):
    """Turn Ctrl-C, SIGTERM and write failures (disk full, file size limit, read-only) into one line
    that says how much was saved; exit 130 for Ctrl-C, 143 for SIGTERM, 2 otherwise."""
    try:
        yield
    except KeyboardInterrupt as exc:
        what, status = registry.stopped_by(exc)
        raise RunInterrupted(f"{what}; {_saved(store, plan)}; rerun the same command to resume", status) from None
    except OSError as exc:
        if exc.errno == errno.ENOENT and _removed(store, exc):
            raise RunStopped(f"{exc.filename or store.dir} vanished during the run (was the parts folder "
                             f"{store.root} removed?); {_saved(store, plan)}; rerun the same command to "
                             "recompute the missing ones") from None
        if exc.errno not in (errno.ENOSPC, errno.EFBIG, errno.EDQUOT, errno.EROFS, errno.EACCES, errno.EIO):
            raise
        what = exc.strerror or str(exc)
        target = f" ({exc.filename})" if exc.filename else ""
        raise RunStopped(f"cannot write{target}: {what}; {_saved(store, plan)}; "
                         "free space (or raise the limit) and rerun the same command to resume") from None
    except RuntimeError as exc:
        if "NetCDF" not in str(exc) and "HDF" not in str(exc):
            raise
        # the netCDF library reports a failed write (EFBIG, ENOSPC) without its errno
        raise RunStopped(f"cannot write {store.target}: the netCDF library failed ({' '.join(str(exc).split())}); "
                         f"{_space(store.target.parent)}; {_saved(store, plan)}; free space (or raise the limit) "
                         "and rerun the same command to resume") from None


def _removed(store, exc: OSError) -> bool:
    """Whether the missing file of ``exc`` is in the run's parts folder (a part, the lock, the assembly's
    temporary file), or that folder is gone: removed by someone while the run went on."""
    names = [n for n in (exc.filename, getattr(exc, "filename2", None)) if n]
    root = store.root.resolve()
    inside = any(root == pathlib.Path(n).resolve() or root in pathlib.Path(n).resolve().parents
                 for n in names if isinstance(n, (str, os.PathLike)))
    return inside or not store.dir.is_dir()


def _space(directory: pathlib.Path) -> str:
    """Free space of ``directory``'s file system and this process's file size limit, in words."""
    parts = []
    try:
        st = os.statvfs(directory)
        parts.append(f"{st.f_bavail * st.f_frsize / 2**20:.0f} MiB free")
    except OSError:
        pass
    try:
        import resource

        soft, _ = resource.getrlimit(resource.RLIMIT_FSIZE)
        if soft != resource.RLIM_INFINITY:
            parts.append(f"file size limit (ulimit -f) {soft} bytes")
    except (ImportError, OSError, ValueError):
        pass
    return ", ".join(parts) or "disk full or a file size limit?"


def _say(text: str, stream=None) -> None:
    """A notice: on ``stream`` when given, else a logging record at INFO (``rimroll._messages``)."""
    if stream is None:
        log.info("%s", text)
        return
    stream.write(f"study: {text}\n")
    stream.flush()


def core_seconds(plan, n_todo: int | None = None) -> float | None:
    """The study's cost model (``Study.cost`` seconds per grid point on one core, in proportion to
    its ``cost_scale`` setting, measured at that setting's ``--quick`` value) for ``n_todo`` chunks
    of ``plan`` (default: all of them); None for a study without a cost."""
    points = float(np.prod(plan.shape, dtype=float))
    if n_todo is not None:
        points *= n_todo / max(plan.n_chunks, 1)
    return plan.study.core_seconds(points, plan.settings)


def check_estimate(plan) -> None:
    """Refuse, before any work, a run whose cost model says more than :data:`MAX_CORE_SECONDS` of
    one core (settings that make a run absurdly large), with the bound in the message."""
    seconds = core_seconds(plan)
    if seconds is not None and seconds > MAX_CORE_SECONDS:
        raise UserError(f"study {plan.study.name!r}: these settings need about {_duration(seconds)} of one core "
                        f"(the study's cost model); at most {_duration(MAX_CORE_SECONDS)} per run: use fewer points "
                        f"or samples, or split the run into several with different --out")


def announce(plan, n_todo: int, stream=None) -> None:
    """One notice with the plan of a run of at least :data:`ANNOUNCE_CHUNKS` chunks to do, or of
    one the study's cost model puts at :data:`ANNOUNCE_SECONDS` or more of one core."""
    seconds = core_seconds(plan, n_todo)
    long = seconds is not None and seconds >= ANNOUNCE_SECONDS
    if n_todo < ANNOUNCE_CHUNKS and not long:
        return
    points = int(np.prod(plan.shape, dtype=float))
    model = f"about {_duration(seconds)} of one core by the study's cost model; " if seconds is not None else ""
    _say(f"{plan.study.name}: {n_todo} of {plan.n_chunks} chunks to compute, {points:.3g} grid "
         f"points; {model}an estimate of the time follows the first chunks (Ctrl-C stops, a rerun resumes)", stream)


def heartbeat(plan, done: int, n_todo: int, elapsed: float, stream=None) -> None:
    """A notice that a run is still working (chunks done, time so far): said by ``study.fanout``
    when no chunk has finished for :data:`HEARTBEATS` seconds, then every minute, so that a long
    chunk is not taken for a hang."""
    _say(f"{plan.study.name}: working, {done} of {n_todo} chunks done after {_duration(elapsed)} "
         "(Ctrl-C stops, a rerun resumes)", stream)


def next_heartbeat(elapsed: float) -> float:
    """When the next :func:`heartbeat` is due, for a run ``elapsed`` seconds in."""
    for t in HEARTBEATS:
        if elapsed < t:
            return t
    return (elapsed // 60 + 1) * 60


def seconds_per_chunk(finished: list[float], threads: int, n_chunks: int) -> float | None:
    """Seconds a chunk takes, for the estimate of the time left, from the compute seconds of the chunks
    ``finished`` so far (in the order they finished); None until there are enough. The first chunk of
    each of the ``threads`` waited for the kernels to compile (a first run: 10-40 s that the later
    chunks do not pay), so the estimate waits for a second round and leaves the first out."""
    if len(finished) < min(2 * threads, n_chunks):
        return None
    later = finished[threads:] or finished  # a run of fewer chunks than two rounds: all of them
    return sum(later) / len(later)


def estimate(plan, seconds_per_chunk: float, n_left: int, threads: int, stream=None) -> None:
    """One notice with the time left, said once when it exceeds a minute."""
    total = seconds_per_chunk * n_left / max(threads, 1)
    if total < 60:
        return
    _say(f"{plan.study.name}: about {_duration(total)} left for {n_left} chunks "
         f"({seconds_per_chunk:.2g} s per chunk on {threads} threads)", stream)


def _duration(seconds: float) -> str:
    if seconds < 60:
        return f"{seconds:.0f} s"
    if seconds < 3600:
        return f"{seconds / 60:.0f} min"
    if seconds < 48 * 3600:
        return f"{seconds / 3600:.1f} h"
    return f"{seconds / 86400:.1f} days"


def status_summary(nc: pathlib.Path) -> str | None:
    """A line counting the lanes whose ``status`` is not ok (flag 0), by meaning; None if all ok.
    ``study run`` prints it as ``study: warning: ...``, ``rimroll.run`` warns with it
    (:class:`rimroll.LaneStatusWarning`)."""
    import xarray as xr

    with xr.open_dataset(nc, engine="netcdf4", chunks={}) as ds:
        if "status" not in ds.data_vars or "flag_values" not in ds["status"].attrs:
            return None
        status = ds["status"]
        values = [int(v) for v in np.atleast_1d(status.attrs["flag_values"])]
        meanings = str(status.attrs.get("flag_meanings", "")).split()
        counts = {v: int((status == v).sum().compute()) for v in values if v != 0}
        n_bad = int((status != 0).sum().compute())
        total = int(status.size)
    bad = {v: n for v, n in counts.items() if n}
    if not n_bad:
        return None
    names = dict(zip(values, meanings))
    detail = ", ".join(f"{n} {names.get(v, f'status {v}')}" for v, n in sorted(bad.items()))
    if n_bad > sum(bad.values()):  # codes the file's flag_values do not name
        detail = ", ".join(filter(None, [detail, f"{n_bad - sum(bad.values())} of unknown status"]))
    return f"{n_bad} of {total} lanes of {nc} did not finish ok ({detail}); see the variable 'status'"
