"""Finished chunks on disk: ``<out>/.parts/<study>-<fingerprint>/chunk-<k>.npz``, and the run lock.

A part is written to a temporary file, flushed to disk and moved into place with
``os.replace``, so it is either complete or absent whatever kills the run. Each part holds its
arrays plus a SHA-256 of their dtype, shape and bytes; a part that fails to load, whose
checksum, names, shapes or dtypes do not match, is treated as missing (deleted and recomputed).
The fingerprint in the folder's name keeps parts of different inputs apart. One run at a time
per folder: ``fcntl.flock`` on ``<study>-<fingerprint>.lock``, non-blocking.
"""

from __future__ import annotations

import contextlib
import fcntl
import hashlib
import os
import pathlib
import shutil
import tempfile
import zipfile

import numpy as np

from study.registry import UserError

PARTS = ".parts"
_SUM = "__sha256__"


def checksum(arrays: dict[str, np.ndarray]) -> str:
    h = hashlib.sha256()
    for name in sorted(arrays):
        a = np.ascontiguousarray(arrays[name])
        h.update(f"{name}|{a.dtype.str}|{a.shape}|".encode())
        h.update(a.tobytes())
    return h.hexdigest()


class PartStore:
    """The part files of one (study, fingerprint)."""

    def __init__(self, out, study: str, fingerprint: str):
        self.root = pathlib.Path(out) / PARTS
        self.dir = self.root / f"{study}-{fingerprint}"
        self.lock_path = self.root / f"{study}-{fingerprint}.lock"
        self.study = study

    def path(self, k: int) -> pathlib.Path:
        return self.dir / f"chunk-{k}.npz"

    @contextlib.contextmanager
    def lock(self):
        """Hold the exclusive run lock; :class:`UserError` if another run holds it."""
        self.root.mkdir(parents=True, exist_ok=True)
        fd = os.open(self.lock_path, os.O_RDWR | os.O_CREAT, 0o644)
        try:
            try:
                fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
            except BlockingIOError:
                raise UserError(f"another run of {self.study!r} with the same inputs is in progress "
                                f"(lock {self.lock_path} is held); wait for it to finish") from None
            os.ftruncate(fd, 0)
            os.write(fd, f"{os.getpid()}\n".encode())
            yield self
        finally:
            os.close(fd)  # releases the lock

    def save(self, k: int, arrays: dict[str, np.ndarray]) -> pathlib.Path:
        """Write chunk ``k`` atomically (temp file, fsync, rename)."""
        self.dir.mkdir(parents=True, exist_ok=True)
        path = self.path(k)
        fd, tmp = tempfile.mkstemp(prefix=f".{path.name}.", suffix=".tmp", dir=self.dir)
        try:
            with os.fdopen(fd, "wb") as fh:
                np.savez(fh, **arrays, **{_SUM: np.array(checksum(arrays))})
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
                names = set(z.files) - {_SUM}
                if names != set(expected) or _SUM not in z.files:
                    return None
                arrays = {name: z[name] for name in names}
                stored = str(z[_SUM])
        except (OSError, ValueError, EOFError, KeyError, zipfile.BadZipFile):
            return None
        for name, (shape, dtype) in expected.items():
            if arrays[name].shape != tuple(shape) or arrays[name].dtype != np.dtype(dtype):
                return None
        return arrays if checksum(arrays) == stored else None

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
            else:
                with contextlib.suppress(OSError):
                    path.unlink()
        return ok

    def remove(self) -> None:
        """Delete the parts folder and the lock file (after a successful assembly)."""
        shutil.rmtree(self.dir, ignore_errors=True)
        with contextlib.suppress(OSError):
            self.lock_path.unlink()
        with contextlib.suppress(OSError):
            self.root.rmdir()  # only if empty
