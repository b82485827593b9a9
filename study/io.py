"""File I/O of results: atomic netCDF4 and PNG writes, and opening rimroll files.

Every write goes to a temporary file in the destination directory and is moved into place
with ``os.replace``, so a reader never sees a half-written file and an interrupted run
leaves nothing behind but the files that were finished. Finished files get the permissions
any new file gets under the user's umask (0666 & ~umask), not the 0600 of a temporary file.
"""

from __future__ import annotations

import contextlib
import os
import pathlib
import tempfile

import xarray as xr

from rimroll.study.registry import UserError

COMPRESSION = {"zlib": True, "complevel": 4}


def current_umask() -> int:
    """The process' umask, read without changing it where Linux allows (``/proc/self/status``)."""
    with contextlib.suppress(OSError, ValueError):
        with open("/proc/self/status") as fh:
            for line in fh:
                if line.startswith("Umask:"):
                    return int(line.split()[1], 8)
    mask = os.umask(0o022)  # elsewhere: set and restore at once
    os.umask(mask)
    return mask


@contextlib.contextmanager
def atomic_path(path: pathlib.Path, tmp_dir=None):
    """Yield a temporary path next to ``path`` (or in ``tmp_dir``, same file system); on success
    move it onto ``path``, else delete it."""
    path = pathlib.Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    fd, tmp = tempfile.mkstemp(prefix=f".{path.name}.", suffix=".tmp", dir=tmp_dir or path.parent)
    os.close(fd)
    try:
        yield pathlib.Path(tmp)
        os.chmod(tmp, 0o666 & ~current_umask())  # mkstemp makes 0600; a result is an ordinary file
        os.replace(tmp, path)
    except BaseException:
        with contextlib.suppress(OSError):
            os.unlink(tmp)
        raise


def encoding_for(ds: xr.Dataset, chunks: tuple[int, ...]) -> dict:
    """netCDF4 encoding: zlib everywhere, data chunked by ``chunks`` (clipped to each shape)."""
    enc = {}
    for name, var in ds.data_vars.items():
        enc[name] = dict(COMPRESSION, chunksizes=tuple(min(c, n) for c, n in zip(chunks, var.shape)))
    for name in ds.coords:
        enc[name] = dict(COMPRESSION, _FillValue=None)
    return enc


def write_dataset(ds: xr.Dataset, path, chunks: tuple[int, ...]) -> pathlib.Path:
    """Write an in-memory ``ds`` to ``path`` as compressed, chunked netCDF4, atomically (files
    that are not assembled from chunks: ``study trace``; studies are written by ``study.assemble``)."""
    path = pathlib.Path(path)
    with atomic_path(path) as tmp:
        ds.to_netcdf(tmp, engine="netcdf4", format="NETCDF4", encoding=encoding_for(ds, chunks))
    return path


def write_figure(fig, path, dpi: int = 120) -> pathlib.Path:
    """Save a matplotlib Figure as PNG at ``dpi``, atomically."""
    path = pathlib.Path(path)
    with atomic_path(path) as tmp:
        fig.savefig(tmp, format="png", dpi=dpi)
    return path


def open_result(path, lazy: bool = False) -> xr.Dataset:
    """Open a rimroll results file; UserError if it is not one.

    Default: loaded into memory, file closed. ``lazy``: dask-backed in the file's chunks
    (``chunks={}``), for cubes larger than memory; close it (``with``) when done.
    """
    path = pathlib.Path(path)
    if not path.is_file():
        raise UserError(f"no such results file: {path}")
    try:
        if lazy:
            ds = xr.open_dataset(path, engine="netcdf4", chunks={})
        else:
            with xr.open_dataset(path, engine="netcdf4") as ds:
                ds = ds.load()
    except (OSError, ValueError) as exc:
        raise UserError(f"cannot read {path} as netCDF: {exc}") from None
    if "study" not in ds.attrs or "rimroll_version" not in ds.attrs:
        ds.close()
        raise UserError(f"{path} is not a rimroll results file (no 'study'/'rimroll_version' attributes)")
    return ds
