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

from rimroll.study import io
from rimroll.study.parts import PARTS
from rimroll.study.registry import UserError

log = logging.getLogger(__name__)

ANNOUNCE_CHUNKS = 100  # runs of at least this many chunks print their plan before starting


class RunStopped(UserError):
    """A run stopped before its end (Ctrl-C, disk full); ``exit_status`` for the command line."""

    def __init__(self, message: str, exit_status: int = 2):
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
    """Turn Ctrl-C and write failures (disk full, file size limit, read-only) into one line that
    says how much was saved; exit 130 for Ctrl-C, 2 otherwise."""
    try:
        yield
    except KeyboardInterrupt:
        raise RunStopped(f"interrupted; {_saved(store, plan)}; rerun the same command to resume",
                         exit_status=130) from None
    except OSError as exc:
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


def announce(plan, n_todo: int, stream=None) -> None:
    """One notice with the plan of a run of at least :data:`ANNOUNCE_CHUNKS` chunks to do."""
    if n_todo < ANNOUNCE_CHUNKS:
        return
    points = int(np.prod(plan.shape, dtype=float))
    _say(f"{plan.study.name}: {n_todo} of {plan.n_chunks} chunks to compute, {points:.3g} grid "
         f"points; an estimate of the time follows the first chunks (Ctrl-C stops, a rerun resumes)", stream)


def estimate(plan, seconds_per_chunk: float, n_left: int, threads: int, stream=None) -> None:
    """One notice with the time left, said once when it exceeds a minute."""
    total = seconds_per_chunk * n_left / max(threads, 1)
    if total < 60:
        return
    _say(f"{plan.study.name}: about {_duration(total)} left for {n_left} chunks "
         f"({seconds_per_chunk:.2g} s per chunk on {threads} threads)", stream)


def _duration(seconds: float) -> str:
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
