"""Finished chunks on disk: ``<out>/.parts/<study>-<fingerprint>/chunk-<k>.npz``, and the run lock.

A part is written to a temporary file, flushed to disk and moved into place with
``os.replace``, so it is either complete or absent whatever kills the run. Each part holds its
arrays, its chunk index and the run's fingerprint, plus a SHA-256 of all of them (names, dtypes,
shapes and bytes); a part that fails to load for any reason, whose checksum, chunk index,
fingerprint, names, shapes or dtypes do not match, is treated as missing (deleted and
recomputed). The fingerprint in the folder's name keeps parts of different inputs apart.

One run at a time per output file: ``fcntl.flock`` on ``<out>/.parts/<study>.lock``,
non-blocking, whatever the inputs (two runs of different inputs never race for
``<out>/<study>.nc``). The parts folders of the study's other fingerprints (runs of other inputs,
interrupted) are never deleted by another run: they are what a user finished computing, and the
rerun of their own command resumes them; a run that finds them names them (:meth:`PartStore.others`).
"""

from __future__ import annotations

import contextlib
import fcntl
import hashlib
import os
import pathlib
import re
import shutil
import tempfile

import numpy as np

from rimroll.study import io
from rimroll.study.registry import UserError

PARTS = ".parts"
_SUM = "__sha256__"
_INDEX = "__chunk__"  # the chunk index, inside the checksummed payload
_FINGERPRINT = "__fingerprint__"  # the run's fingerprint, inside the checksummed payload


def checksum(arrays: dict[str, np.ndarray]) -> str:
    h = hashlib.sha256()
    for name in sorted(arrays):
        a = np.ascontiguousarray(arrays[name])
        h.update(f"{name}|{a.dtype.str}|{a.shape}|".encode())
        h.update(a.tobytes())
    return h.hexdigest()


def run_in_progress(target) -> str | None:
    """What a run writing the results file ``target`` (``<out>/<study>.nc``) holds: a phrase naming the
    run's lock file ``<out>/.parts/<study>.lock`` and its process, or None when no run holds that lock.
    The file appears only when the run finishes (it is written whole), so until then it is missing."""
    target = pathlib.Path(target)
    lock = target.parent / PARTS / f"{target.stem}.lock"
    try:
        fd = os.open(lock, os.O_RDONLY)
    except OSError:
        return None
    try:
        try:
            fcntl.flock(fd, fcntl.LOCK_SH | fcntl.LOCK_NB)
        except BlockingIOError:
            pid = os.read(fd, 32).decode(errors="replace").strip()
            return f"a run of {target.stem!r} is writing it (lock {lock} held" + (f" by process {pid})" if pid else ")")
        except OSError:
            return None
        fcntl.flock(fd, fcntl.LOCK_UN)
        return None
    finally:
        os.close(fd)


class PartStore:
    """The part files of one (study, fingerprint)."""

    def __init__(self, out, study: str, fingerprint: str):
        self.root = pathlib.Path(out) / PARTS
        self.dir = self.root / f"{study}-{fingerprint}"
        self.lock_path = self.root / f"{study}.lock"
        self.study = study
        self.fingerprint = fingerprint
        self.target = pathlib.Path(out) / f"{study}.nc"

    def path(self, k: int) -> pathlib.Path:
        return self.dir / f"chunk-{k}.npz"

    @contextlib.contextmanager
    def lock(self):
        """Hold the exclusive lock of the output file; :class:`UserError` if another run holds it.
        The lock file is deleted on leaving; a file in the place of the parts folder, or a
        directory in the lock's, is a :class:`UserError` naming it."""
        if self.root.exists() and not self.root.is_dir():
            raise UserError(f"cannot write the parts folder {self.root}: a file is in the way (remove it)")
        io.check_target(self.lock_path, "the lock")
        self.root.mkdir(parents=True, exist_ok=True)
        while True:
            fd = os.open(self.lock_path, os.O_RDWR | os.O_CREAT, 0o644)
            try:
                fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
            except BlockingIOError:
                os.close(fd)
                raise UserError(f"another run of {self.study!r} into {self.target} is in progress "
                                f"(lock {self.lock_path} is held); wait for it to finish or use another --out"
                                ) from None
            try:  # the file may have been deleted by the run that held it: lock the current one
                same = os.fstat(fd).st_ino == os.stat(self.lock_path).st_ino
            except FileNotFoundError:
                same = False
            if same:
                break
            os.close(fd)
        try:
            os.ftruncate(fd, 0)
            os.write(fd, f"{os.getpid()}\n".encode())
            yield self
        finally:
            # no stale lock file: deleted while held (a run that opened it meanwhile sees another
            # inode above and retries), then released
            with contextlib.suppress(OSError):
                self.lock_path.unlink()
            with contextlib.suppress(OSError):
                self.root.rmdir()  # only if empty
            os.close(fd)

    def save(self, k: int, arrays: dict[str, np.ndarray]) -> pathlib.Path:
        """Write chunk ``k`` atomically (temp file, fsync, rename). A parts folder removed while the run
        goes on (its temporary file with it) is made again and the part written once more: the chunk
        is in memory, and only the chunks saved before the removal are lost (the assembly says so)."""
        try:
            return self._save(k, arrays)
        except FileNotFoundError:
            return self._save(k, arrays)

    def _save(self, k: int, arrays: dict[str, np.ndarray]) -> pathlib.Path:
        self.dir.mkdir(parents=True, exist_ok=True)
        path = self.path(k)
        payload = {**arrays, _INDEX: np.array(int(k), dtype=np.int64), _FINGERPRINT: np.array(self.fingerprint)}
        fd, tmp = tempfile.mkstemp(prefix=f".{path.name}.", suffix=".tmp", dir=self.dir)
        try:
            with os.fdopen(fd, "wb") as fh:
                np.savez(fh, **payload, **{_SUM: np.array(checksum(payload))})
                fh.flush()
                os.fsync(fh.fileno())
            os.replace(tmp, path)
        except BaseException:
            with contextlib.suppress(OSError):
                os.unlink(tmp)
            raise
        return path

    def load(self, k: int, expected: dict) -> dict[str, np.ndarray] | None:
        """Arrays of chunk ``k`` if its part is present and intact, else None.

        ``expected``: ``{name: (shape, dtype)}``; any mismatch counts as corrupt.
        """
        path = self.path(k)
        try:
            with np.load(path, allow_pickle=False) as z:
                names = set(z.files) - {_SUM, _INDEX, _FINGERPRINT}
                if names != set(expected) or not {_SUM, _INDEX, _FINGERPRINT} <= set(z.files):
                    return None
                payload = {name: z[name] for name in set(z.files) - {_SUM}}
                stored = str(z[_SUM])
        except Exception:  # noqa: BLE001  any damage (zip directory, compression method, ...) = missing
            return None
        for name, (shape, dtype) in expected.items():
            if payload[name].shape != tuple(shape) or payload[name].dtype != np.dtype(dtype):
                return None
        if checksum(payload) != stored:
            return None
        if payload[_INDEX].shape != () or int(payload[_INDEX]) != k or str(payload[_FINGERPRINT]) != self.fingerprint:
            return None  # a part of another chunk or another run, copied or renamed here
        return {name: payload[name] for name in expected}

    def valid(self, n: int, expected) -> set[int]:
        """Chunks whose parts are intact; corrupt parts and stale temporary files are deleted.

        ``expected(k)`` gives the ``{name: (shape, dtype)}`` of chunk ``k``. Call with the lock held.
        """
        if not self.dir.is_dir():
            return set()
        for tmp in self.dir.glob(".*.tmp"):  # parts or an assembly cut short
            with contextlib.suppress(OSError):
                tmp.unlink()
        ok = set()
        for path in self.dir.glob("chunk-*.npz"):
            try:
                k = int(path.stem.split("-", 1)[1])
            except ValueError:
                continue
            if 0 <= k < n and self.load(k, expected(k)) is not None:
                ok.add(k)
            elif path.is_dir() and not path.is_symlink():  # a folder in a part's place: ours to clear
                shutil.rmtree(path, ignore_errors=True)
            else:
                with contextlib.suppress(OSError):
                    path.unlink()
        return ok

    def others(self) -> list[tuple[pathlib.Path, int]]:
        """The parts folders of this study left by other fingerprints (runs of other inputs that were
        interrupted), with the number of chunk files in each; they are kept for those runs to resume."""
        pattern = re.compile(re.escape(self.study) + r"-[0-9a-f]{16}")
        if not self.root.is_dir():
            return []
        return [(d, len(list(d.glob("chunk-*.npz")))) for d in sorted(self.root.iterdir())
                if d != self.dir and d.is_dir() and pattern.fullmatch(d.name)]

    def count(self) -> int:
        """Part files present now (finished chunks; for messages)."""
        return len(list(self.dir.glob("chunk-*.npz"))) if self.dir.is_dir() else 0

    def remove(self) -> None:
        """Delete the parts folder and the lock file (after a successful assembly)."""
        shutil.rmtree(self.dir, ignore_errors=True)
        with contextlib.suppress(OSError):
            self.lock_path.unlink()
        with contextlib.suppress(OSError):
            self.root.rmdir()  # only if empty
