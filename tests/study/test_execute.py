"""Faults of the disk while a run writes (``study.execute``): a full disk or a file size limit is one line
that says what was saved.
"""

from __future__ import annotations

import errno
import os

from rimroll.study.cli import main
from rimroll.study.parts import PartStore
from tests.helpers.study_runs import N_PROBE, cli, error_after_notices, one_line_error, parts_of, run_probe


def test_disk_full_mid_run_says_what_was_saved(probe, tmp_path, capsys, monkeypatch):
    real = PartStore.save
    calls = []

    def save(self, k, arrays):
        calls.append(k)
        if len(calls) > 3:
            raise OSError(errno.ENOSPC, "No space left on device", str(self.path(k)))
        return real(self, k, arrays)

    monkeypatch.setattr(PartStore, "save", save)
    assert run_probe(tmp_path, "--workers", "1") == 2
    error_after_notices(capsys.readouterr().err, "No space left on device", f"3 of {N_PROBE} chunks saved", "rerun")
    assert len(parts_of(tmp_path)) == 3 and not list((tmp_path / ".parts").glob("*.lock"))
    monkeypatch.setattr(PartStore, "save", real)
    assert run_probe(tmp_path) == 0 and f"3 of {N_PROBE} chunks resumed" in capsys.readouterr().out


def test_file_size_limit_mid_run_is_one_line(tmp_path):
    import resource

    def limit():
        resource.setrlimit(resource.RLIMIT_FSIZE, (16_000, 16_000))  # parts fit, the assembled file does not

    run = cli("run", "fanout-probe", "--out", str(tmp_path), "--no-progress", "--set", "n_x=60",
              preexec_fn=limit)
    assert run.returncode == 2, run.stderr
    error_after_notices(run.stderr, "file size limit (ulimit -f) 16000 bytes", "chunks saved")
    assert not (tmp_path / "fanout-probe.nc").exists()
    rerun = cli("run", "fanout-probe", "--out", str(tmp_path), "--no-progress", "--set", "n_x=60")
    assert rerun.returncode == 0 and "chunks resumed" in rerun.stdout, rerun.stderr


def test_disk_full_from_the_start_is_one_line(probe, tmp_path, capsys, monkeypatch):
    import errno

    from rimroll.study import parts

    def full(fd, data):
        raise OSError(errno.ENOSPC, os.strerror(errno.ENOSPC))

    monkeypatch.setattr(parts.os, "write", full)  # the first write of a run: the lock's pid
    assert run_probe(tmp_path) == 2
    one_line_error(capsys.readouterr().err, "No space left on device", "0 of 12 chunks saved")


def test_file_size_limit_between_the_netcdf_and_the_png_is_one_line(tmp_path, capsys, monkeypatch):
    import errno

    from rimroll.study import io as study_io

    def too_large(fig, path, dpi=120):
        raise OSError(errno.EFBIG, os.strerror(errno.EFBIG), str(path))

    monkeypatch.setattr(study_io, "write_figure", too_large)
    assert main(["run", "fig8", "--quick", "--no-progress", "--out", str(tmp_path)]) == 2
    one_line_error(capsys.readouterr().err, "File too large", str(tmp_path / "fig8.png"))
    monkeypatch.undo()
    assert main(["run", "fig8", "--quick", "--no-progress", "--out", str(tmp_path)]) == 0  # the file is kept
    assert "exists, not recomputing" in capsys.readouterr().out and (tmp_path / "fig8.png").is_file()
