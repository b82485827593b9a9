"""When an existing result may stand for a new request: the run fingerprint rule.

``study run`` records the fingerprint of its plan (:attr:`study.plan.Plan.fingerprint`: the
study, every setting and parameter, the grid, the chunking and the code version) in the global
attribute ``run_fingerprint`` of the file it writes. A later run into the same ``--out`` reuses
the file only if that attribute equals the new plan's fingerprint and the file still records the
checksums of its values, all of them and only them (``study.io.seal_problem``; a file changed on purpose
drops or empties them: it is not reused). A file that cannot be read (truncated, not netCDF, values or a
seal that do not match: garbled, missing a variable's entry, an entry for a variable it does not hold) is
not a result: it is recomputed and replaced atomically. A readable
file of other inputs is neither reused nor overwritten without ``--force``; the error names
what differs.
"""

from __future__ import annotations

import dataclasses
import pathlib

FINGERPRINT_ATTR = "run_fingerprint"


@dataclasses.dataclass(frozen=True)
class Existing:
    """What is at the output path: ``state`` is 'absent', 'unreadable', 'same' or 'different'."""

    state: str
    detail: str = ""  # unreadable: why; different: what differs


def _read_header(path: pathlib.Path) -> tuple[dict, dict, bool]:
    """Global attributes and dimension sizes of a netCDF file, and whether it is sealed, after reading
    every data block of it (``study.io.read_all``: each block's checksum, and a seal that covers every
    variable exactly), so that a file cut short, damaged or edited under a seal anywhere raises here and
    is recomputed, never reused. Any failure raises."""
    import netCDF4

    from rimroll.study.io import read_all

    sealed = read_all(path)
    with netCDF4.Dataset(path, "r") as nc:
        attrs = {k: nc.getncattr(k) for k in nc.ncattrs()}
        sizes = {k: len(d) for k, d in nc.dimensions.items()}
    return attrs, sizes, sealed


def _same(a, b) -> bool:
    try:
        return float(a) == float(b) or str(a) == str(b)
    except (TypeError, ValueError):
        return str(a) == str(b)


def differences(file_attrs: dict, file_sizes: dict, request_attrs: dict, request_sizes: dict) -> list[str]:
    """Human-readable differences of recorded parameters, settings and grid sizes."""
    out = []
    keys = sorted(k for k in {*file_attrs, *request_attrs}
                  if k.startswith(("param_", "setting_")) or k in ("study", "swept", "rimroll_version"))
    for key in keys:
        mine, theirs = file_attrs.get(key, "(none)"), request_attrs.get(key, "(none)")
        if not _same(mine, theirs):
            out.append(f"{key} {mine} in the file, {theirs} requested")
    if dict(file_sizes) != dict(request_sizes):
        out.append(f"grid {dict(file_sizes)} in the file, {dict(request_sizes)} requested")
    return out


def inspect(path, fingerprint: str, request_attrs: dict, request_sizes: dict) -> Existing:
    """Whether the file at ``path`` is absent, unreadable, the same run, or a different one."""
    path = pathlib.Path(path)
    if not path.exists():
        return Existing("absent")
    try:
        attrs, sizes, sealed = _read_header(path)
    except Exception as exc:  # noqa: BLE001  whatever the damage, it is not a result
        return Existing("unreadable", " ".join(str(exc).split()) or type(exc).__name__)
    if attrs.get(FINGERPRINT_ATTR) == fingerprint:
        from rimroll.study.io import CHECKSUM_ATTR  # io is imported with the header's read (_read_header)

        if not sealed:  # removed or emptied by whoever changed the file on purpose: not this run's numbers
            return Existing("different", f"the file records this run's fingerprint but no {CHECKSUM_ATTR}: it was "
                                         "changed after it was written")
        return Existing("same")
    diff = differences(attrs, sizes, request_attrs, request_sizes)
    if FINGERPRINT_ATTR not in attrs:
        diff.append("the file records no run fingerprint")
    elif not diff:
        diff.append("chunking or code version differs")
    return Existing("different", "; ".join(diff))
