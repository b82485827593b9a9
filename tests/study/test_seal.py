"""One rule of what counts as a result's seal (``study.io.seal_problem``): the checksums
(``data_sha256``) of every variable and of the global attributes, each once, nothing else.

A file whose seal is emptied, garbled, short of a variable's entry or silent about a variable
added to it is never reused as the run its fingerprint names, and never read as numbers that
rimroll vouches for. The cases are generated: every variable of a real result, every kind of damage.
"""

from __future__ import annotations

import shutil

import netCDF4
import numpy as np
import pytest
import xarray as xr

from rimroll.study import existing_result, io
from rimroll.study.cli import main
from rimroll.study.io import CHECKSUM_ATTR
from rimroll.study.registry import UserError

STUDY = "fig8"  # a closed-form map: its --quick run takes well under a second


@pytest.fixture(scope="module")
def sealed(tmp_path_factory):
    """A fresh --quick result (sealed), its variables and its fingerprint."""
    out = tmp_path_factory.mktemp("sealed")
    assert main(["run", STUDY, "--quick", "--out", str(out), "--no-progress"]) == 0
    path = out / f"{STUDY}.nc"
    with netCDF4.Dataset(path) as nc:
        names = sorted(nc.variables)
        fingerprint = nc.getncattr(existing_result.FINGERPRINT_ATTR)
    return path, names, fingerprint


def _entries(nc) -> dict:
    return dict(w.split(":", 1) for w in str(nc.getncattr(CHECKSUM_ATTR)).split())


def _write(nc, entries: dict) -> None:
    nc.setncattr(CHECKSUM_ATTR, " ".join(f"{k}:{v}" for k, v in entries.items()))


def _edit_value(nc, name: str) -> None:
    """Change one stored value of variable ``name`` (a number, a character)."""
    var = nc.variables[name]
    var.set_auto_maskandscale(False)
    values = np.array(var[...])
    flat = values.reshape(-1)
    if flat.dtype.kind in "fiu":
        flat[0] = flat[0] + 1
    else:
        flat[0] = b"Z" if flat[0] != b"Z" else b"Y"
    var[...] = values


def _damage(nc, kind: str, name: str | None) -> None:
    entries = _entries(nc)
    if kind == "garbled":  # the variable's entry no longer a digest, its values edited
        entries[name] = entries[name][:-3] + "xyz"
        _edit_value(nc, name) if name != ".attrs" else nc.setncattr("setting_edited", 1)
    elif kind == "missing":  # the variable's entry removed, its values edited
        del entries[name]
        _edit_value(nc, name) if name != ".attrs" else nc.setncattr("setting_edited", 1)
    elif kind == "truncated":  # the variable's entry cut short (its values unchanged)
        entries[name] = entries[name][:8]
    elif kind == "twice":  # the variable's entry repeated with another digest
        _write(nc, entries)
        nc.setncattr(CHECKSUM_ATTR, str(nc.getncattr(CHECKSUM_ATTR)) + f" {name}:{'0' * 32}")
        return
    elif kind == "extra":  # an entry of a variable the file does not hold
        entries["not_in_the_file"] = "0" * 32
    elif kind == "added":  # a variable added to the file, not covered by the seal
        nc.createVariable("added", "f8", ())[...] = 1.0
    _write(nc, entries)


PER_VARIABLE = ("garbled", "missing", "truncated", "twice")
FILE_WIDE = ("extra", "added", "emptied", "blank")


def _check(path, kind: str, name: str | None, fingerprint: str, edited_first: str) -> None:
    """Damage the file at ``path`` by ``kind`` (of variable ``name``), then: not the run, not read as sealed."""
    with netCDF4.Dataset(path, "a") as nc:
        if kind in ("emptied", "blank"):  # the seal dropped by whoever edited the file: readable, not reused
            nc.setncattr(CHECKSUM_ATTR, "" if kind == "emptied" else "  ")
            _edit_value(nc, edited_first)
        else:
            _damage(nc, kind, name)
    with xr.open_dataset(path) as ds:
        attrs, sizes = dict(ds.attrs), dict(ds.sizes)
    found = existing_result.inspect(path, fingerprint, attrs, sizes)
    assert found.state != "same", (kind, name)
    if kind in ("emptied", "blank"):
        assert found.state == "different" and CHECKSUM_ATTR in found.detail
        io.open_result(path).close()  # a file changed on purpose still reads
    else:
        assert found.state == "unreadable" and CHECKSUM_ATTR in found.detail, (kind, name, found)
        with pytest.raises(UserError, match=CHECKSUM_ATTR):
            io.open_result(path)


@pytest.mark.parametrize("every", [pytest.param(True, marks=pytest.mark.slow, id="every-variable"),
                                   pytest.param(False, id="three-variables")])
@pytest.mark.parametrize("kind", PER_VARIABLE + FILE_WIDE)
def test_a_damaged_seal_is_never_reused_or_read(sealed, tmp_path, kind, every):
    """Every variable the file holds (coordinates, settings as scalar coordinates, label arrays, data)
    and its global attributes (``.attrs``), each damaged by ``kind``; the file-wide kinds once. The
    default run takes the first and last variable and the attributes (all of them: ``-m slow``)."""
    source, names, fingerprint = sealed
    chosen = names if every else [names[0], names[-1]]
    targets = [*chosen, ".attrs"] if kind in PER_VARIABLE else [None]
    assert len(targets) == 1 or len(names) >= 3
    for name in targets:
        path = tmp_path / f"{kind}-{name}.nc"
        shutil.copy(source, path)
        _check(path, kind, name, fingerprint, names[0])


def test_the_sealed_file_itself_is_reused(sealed):
    """The cases above fail for their damage, not for the file: untouched, it is the run."""
    path, _, fingerprint = sealed
    with xr.open_dataset(path) as ds:
        attrs, sizes = dict(ds.attrs), dict(ds.sizes)
    assert existing_result.inspect(path, fingerprint, attrs, sizes).state == "same"
    assert io.read_all(path) is True


def test_a_rerun_replaces_a_file_with_a_garbled_seal(sealed, tmp_path, capsys):
    """End to end: the same command recomputes (one warning) instead of 'exists, not recomputing'."""
    source, names, _ = sealed
    shutil.copy(source, tmp_path / source.name)
    with netCDF4.Dataset(tmp_path / source.name, "a") as nc:
        good = np.array(nc.variables[names[-1]][...])
        _damage(nc, "missing", names[-1])
    capsys.readouterr()
    assert main(["run", STUDY, "--quick", "--out", str(tmp_path), "--no-progress"]) == 0
    captured = capsys.readouterr()
    assert "not recomputing" not in captured.out
    with netCDF4.Dataset(tmp_path / source.name) as nc:
        np.testing.assert_array_equal(np.array(nc.variables[names[-1]][...]), good)
    assert io.read_all(tmp_path / source.name) is True
