"""File I/O of results: atomic netCDF4 and PNG writes, and opening rimroll files.

Every write goes to a temporary file in the destination directory and is moved into place
with ``os.replace``, so a reader never sees a half-written file and an interrupted run
leaves nothing behind but the files that were finished. Finished files get the permissions
any new file gets under the user's umask (0666 & ~umask), not the 0600 of a temporary file.
"""

from __future__ import annotations

import contextlib
import hashlib
import itertools
import os
import pathlib
import re
import tempfile

import numpy as np
import xarray as xr

from rimroll.study.registry import UserError

COMPRESSION = {"zlib": True, "complevel": 4, "fletcher32": True}
"""Filters of every array written: zlib, and a Fletcher-32 checksum of each storage chunk, so that
a damaged block is an error on reading (:func:`read_all`), never numbers."""


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


def _name_max(directory: pathlib.Path) -> int:
    """The longest file name the file system of ``directory`` (or its nearest existing parent) takes."""
    for d in (directory, *directory.parents):
        with contextlib.suppress(OSError, ValueError, AttributeError):
            return int(os.pathconf(d, "PC_NAME_MAX"))  # fails for a folder that is not there
    return 255


def name_problem(path) -> str | None:
    """A component of ``path`` too long for the file system, in words; None if there is none."""
    path = pathlib.Path(path)
    limit = _name_max(path.parent)
    for part in path.parts:
        if len(os.fsencode(part)) > limit:
            return f"the name {part[:20]}... is {len(os.fsencode(part))} bytes long, the file system takes {limit}"
    return None


def _in_the_way(path: pathlib.Path) -> str | None:
    """What keeps a file from being written at ``path``, in words; None if nothing does."""
    problem = name_problem(path)
    if problem:
        return problem
    try:
        for d in reversed(path.parents):
            if d.exists() and not d.is_dir():
                return f"{d} is a file, not a directory"
        if path.is_dir():
            return "a directory is in the way"
        if path.exists() and not path.is_file():
            return "something that is not a regular file is in the way"
    except OSError as exc:  # a loop of links, a folder we may not search
        return exc.strerror or str(exc)
    return None


def check_target(path, what: str = "") -> pathlib.Path:
    """The one guard of a path the command line writes (results, figures, parts, locks): a
    :class:`UserError` naming the path and what is in the way (a directory at the file's place, a
    file at a directory's place, a name too long for the file system); else ``path``. ``what``: the
    role of the path in the message ("the lock")."""
    path = pathlib.Path(path)
    problem = _in_the_way(path)
    if problem:
        raise UserError(f"cannot write {what + ' ' if what else ''}{path}: {problem}")
    return path


@contextlib.contextmanager
def atomic_path(path: pathlib.Path, tmp_dir=None):
    """Yield a temporary path next to ``path`` (or in ``tmp_dir``, same file system); on success
    move it onto ``path``, else delete it. ``path`` is checked first (:func:`check_target`)."""
    path = check_target(path)
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
        seal(tmp)
    return path


def write_figure(fig, path, dpi: int = 120) -> pathlib.Path:
    """Save a matplotlib Figure as PNG at ``dpi``, atomically."""
    path = pathlib.Path(path)
    with atomic_path(path) as tmp:
        fig.savefig(tmp, format="png", dpi=dpi)
    return path


TRACE_VARIABLES = ("beta", "omega1", "omega2", "omega3", "F2", "friction_use", "energy", "x", "y", "z",
                   "phase", "event_time", "event_kind")
"""What a file of ``study trace`` holds (``study.rim_trace.dataset``) and its figure draws."""
SHOT_TRACE_VARIABLES = ("x", "y", "z", "phase", "impact_time", "impact_x", "impact_y", "impact_z", "impact_kind")
"""What a file of ``study trace --release`` (one shot, ``study.shot_trace``) holds."""


CHECKSUM_ATTR = "data_sha256"
"""Global attribute of a result: ``NAME:DIGEST`` words, the SHA-256 (first 32 hex digits) of every
variable's stored values, and of the global attributes that give the file its meaning (``.attrs``;
:func:`seal`);
:func:`read_all` recomputes and compares them, so that a
damaged file is refused or recomputed, never read as numbers (a flipped byte in a chunk index
makes the netCDF library return fill values without an error)."""


class DamagedFile(ValueError):
    """A variable of a file no longer matches its checksum."""


_SLAB = 1 << 22  # values read at once when a variable is hashed


def _slabs(var):
    """The values of netCDF4 variable ``var`` in C order, in slabs of at most about :data:`_SLAB`
    values (whatever its storage chunks: the digest does not depend on how the file is chunked)."""
    var.set_auto_maskandscale(False)
    shape = var.shape
    if var.ndim == 0 or var.size == 0:
        yield np.asarray(var[...])
        return
    lead = 0  # leading dimensions iterated one index at a time
    while lead < len(shape) - 1 and int(np.prod(shape[lead:], dtype=float)) > _SLAB:
        lead += 1
    for prefix in itertools.product(*(range(n) for n in shape[:lead])):
        yield np.asarray(var[prefix] if prefix else var[...])


def _attrs_digest(nc) -> str:
    """SHA-256 of the global attributes that give a result its meaning (the study, its swept axes,
    the run's fingerprint, every parameter and setting)."""
    keys = sorted(k for k in nc.ncattrs() if k in ("study", "swept", "run_fingerprint")
                  or k.startswith(("param_", "setting_")))
    pairs = [(k, np.asarray(nc.getncattr(k)).tolist()) for k in keys]
    return hashlib.sha256(repr(pairs).encode()).hexdigest()[:32]


def _digests(nc) -> dict[str, str]:
    """Variable name -> the SHA-256 of its dtype, shape and stored values in C order (reads every
    value); ``.attrs``: of the global attributes that give the file its meaning."""
    out = {".attrs": _attrs_digest(nc)}
    for name, var in nc.variables.items():
        h = hashlib.sha256(f"{name}|{var.dtype}|{var.shape}|".encode())
        for slab in _slabs(var):
            h.update(np.ascontiguousarray(slab).tobytes())
        out[name] = h.hexdigest()[:32]
    return out


def seal(path) -> None:
    """Record the checksum of every variable of the netCDF file ``path`` (:data:`CHECKSUM_ATTR`);
    call on the finished temporary file, before it is moved into place."""
    import netCDF4

    with netCDF4.Dataset(path, "a") as nc:
        nc.setncattr(CHECKSUM_ATTR, " ".join(f"{k}:{v}" for k, v in sorted(_digests(nc).items())))


_DIGEST = re.compile(r"[0-9a-f]{32}")


def seal_problem(recorded: str, found: dict) -> str | None:
    """What keeps the text ``recorded`` of :data:`CHECKSUM_ATTR` from being the complete seal of a file
    whose digests are ``found`` (:func:`_digests`), or None where it is one: every word is
    ``NAME:DIGEST`` (32 hex digits) with each name once, it names exactly the file's variables and
    ``.attrs``, and every digest matches. The one rule of what counts as a seal (read, reuse)."""
    words = recorded.split()
    pairs = [w.split(":", 1) if ":" in w else (w, "") for w in words]
    garbled = [w for w, (_, digest) in zip(words, pairs) if not _DIGEST.fullmatch(digest)]
    if garbled:
        return f"garbled entries {_some(garbled)}"
    names = [name for name, _ in pairs]
    twice = sorted({n for n in names if names.count(n) > 1})
    if twice:
        return f"entries named twice: {_some(twice)}"
    expected = dict(pairs)
    missing, extra = sorted(set(found) - set(expected)), sorted(set(expected) - set(found))
    if missing:
        return f"no checksum of {_some(_labels(missing))} (a value not covered by the seal)"
    if extra:
        return f"checksums of {_some(extra)}, which the file does not hold"
    bad = sorted(k for k in found if expected[k] != found[k])
    if bad:
        return f"the values of {_some(_labels(bad))} do not match the checksums"
    return None


def _labels(names: list) -> list:
    return ["the global attributes" if k == ".attrs" else k for k in names]


def _some(items: list, n: int = 5) -> str:
    return ", ".join(map(str, items[:n])) + (" ..." if len(items) > n else "")


def read_all(path) -> bool:
    """Read every value of every variable of the netCDF file ``path``, a slab at a time (memory: a
    few million values), so that damage anywhere raises here: a block failing its Fletcher-32
    checksum (:data:`COMPRESSION`) or its decompression (``RuntimeError: NetCDF: HDF error``), or a
    :data:`CHECKSUM_ATTR` that is not the complete seal of what the file holds (:func:`seal_problem`:
    :class:`DamagedFile`). Returns True for a sealed file, False for one that records no checksums
    (written before they were recorded, or changed on purpose: the attribute removed or emptied)."""
    import netCDF4

    with netCDF4.Dataset(path, "r") as nc:
        found = _digests(nc)
        recorded = str(nc.getncattr(CHECKSUM_ATTR)) if CHECKSUM_ATTR in nc.ncattrs() else ""
    if not recorded.strip():
        return False
    problem = seal_problem(recorded, found)
    if problem:
        raise DamagedFile(f"{CHECKSUM_ATTR} is not this file's seal: {problem}; the file is damaged or was "
                          f"edited (a file changed on purpose must drop the attribute {CHECKSUM_ATTR})")
    return True


def open_result(path, lazy: bool = False) -> xr.Dataset:
    """Open a rimroll results file, the one reader that validates before anything interprets it:
    :class:`UserError` (one line: what the file lacks or where it is damaged) if it is not one.

    Checked: it opens as netCDF, the ``study`` and ``rimroll_version`` attributes, the variables of
    the study it names, its flags and swept axes (:func:`problems`), then every value reads and
    matches the checksums the file records (:func:`read_all`).
    Default: loaded into memory, file closed. ``lazy``: dask-backed in the file's chunks
    (``chunks={}``), for cubes larger than memory; close it (``with``) when done.
    """
    path = pathlib.Path(path)
    if not path.is_file():
        from rimroll.study import parts  # parts imports io

        writing = parts.run_in_progress(path)
        raise UserError(f"no such results file: {path}" + (f" yet: {writing}; open it when that run has finished"
                                                            if writing else ""))
    damaged = (OSError, ValueError, RuntimeError, KeyError, IndexError, TypeError, AttributeError)
    try:
        if lazy:
            ds = xr.open_dataset(path, engine="netcdf4", chunks={})
        else:
            with xr.open_dataset(path, engine="netcdf4") as ds:
                ds = ds.load()
    except damaged as exc:
        raise _unreadable(path, exc) from None
    if "study" not in ds.attrs or "rimroll_version" not in ds.attrs:
        ds.close()
        raise UserError(f"{path} is not a rimroll results file (no 'study'/'rimroll_version' attributes)")
    problem = problems(ds)
    if problem:
        ds.close()
        raise UserError(f"{path} is not a valid rimroll results file: {problem}")
    try:
        read_all(path)  # what it holds is what was written: every block, every recorded checksum
    except damaged as exc:
        ds.close()
        raise _unreadable(path, exc) from None
    return ds


def _unreadable(path: pathlib.Path, exc: BaseException) -> UserError:
    return UserError(f"cannot read {path}: it is damaged or not netCDF: "
                     f"{' '.join(str(exc).split()) or type(exc).__name__}")


def problems(ds: xr.Dataset) -> str | None:
    """What a dataset with a ``study`` attribute lacks to be a file of that study, in words (None:
    nothing): the study's variables (a registered study's, or :data:`TRACE_VARIABLES`), flags that
    pair a 1-D list of integer ``flag_values`` with as many ``flag_meanings``, and ``swept`` names
    that are numeric axes of the file."""
    from rimroll.study import registry

    name = ds.attrs["study"]
    if not isinstance(name, str) or not name:
        return f"its 'study' attribute is {name!r}, not a study name"
    if name == "trace":
        required, axes = TRACE_VARIABLES, ("time", "event")
    elif name == "shot-trace":
        required, axes = SHOT_TRACE_VARIABLES, ("time", "impact")
    else:
        try:
            study = registry.get(name)
        except UserError:
            return f"it names study {name!r}, which no installed package registers"
        # a variable never compared (refine_level, timings) may be missing from an older file
        required, axes = [v.name for v in study.variables if v.compared], _grid_names(study)
    missing = [v for v in required if v not in ds.data_vars]
    if missing:
        return f"it lacks the variable(s) {', '.join(missing)} of study {name}"
    allowed = {*axes, *str(ds.attrs.get("swept", "")).split()}
    for v in required:
        extra = [d for d in ds[v].dims if d not in allowed]
        if extra:
            return (f"its variable {v} has the dimension(s) {', '.join(extra)}, which study {name} does not have "
                    f"(its axes: {', '.join(sorted(allowed))})")
    for var_name, var in ds.variables.items():
        flag = _flag_problem(var.attrs)
        if flag:
            return f"variable {var_name}: {flag}"
    for axis in str(ds.attrs.get("swept", "")).split():
        if axis not in ds.dims or axis not in ds.coords or ds[axis].dtype.kind not in "iufUSO":
            return f"its 'swept' attribute names {axis!r}, which is not an axis of numbers or labels of the file"
    return None


def _grid_names(study) -> tuple:
    """Names of the study's grid axes at its default settings (they do not depend on the settings);
    empty when they cannot be made."""
    from rimroll.study.settings import base_settings, default_settings

    try:
        return tuple(a.name for a in study.axes(base_settings(default_settings(study))))
    except Exception:  # noqa: BLE001  a study whose axes need other settings: no check of dimensions
        return ()


def _flag_problem(attrs: dict) -> str | None:
    """What is wrong with a variable's CF flags (flag_meanings with flag_values or flag_masks, CF 3.5),
    or None."""
    keys = [key for key in ("flag_values", "flag_masks") if key in attrs]
    if not keys and "flag_meanings" not in attrs:
        return None
    meanings = attrs.get("flag_meanings")
    if not isinstance(meanings, str):
        return f"{(keys or ['flag_values'])[0]} without flag_meanings (a string of words)"
    if not keys:
        return "flag_meanings without flag_values (a list of integers)"
    for key in keys:
        values = np.asarray(attrs[key])
        if values.ndim != 1 or values.dtype.kind not in "iu":
            return f"flag_meanings without {key} (a list of integers)"
        if values.size != len(meanings.split()):
            return f"{values.size} {key} but {len(meanings.split())} flag_meanings"
    return None
    meanings = attrs.get("flag_meanings")
    if not isinstance(meanings, str):
        return "flag_values or flag_masks without flag_meanings (a string of words)"
    for key in ("flag_values", "flag_masks"):
        if key not in attrs:
            continue
        values = np.asarray(attrs[key])
        if values.ndim != 1 or values.dtype.kind not in "iu":
            return f"{key} is not a list of integers"
        if values.size != len(meanings.split()):
            return f"{values.size} {key} but {len(meanings.split())} flag_meanings"
    if "flag_values" not in attrs and "flag_masks" not in attrs:
        return "flag_meanings without flag_values or flag_masks (a list of integers)"
    return None
