"""A damaged entry of the kernel cache is rebuilt with one warning, never a traceback.

A toy kernel compiled through rimroll's one compilation policy (``solver._jit.njit_cached``) in a
fresh process, its cache files then damaged in each way a disk or an interrupted copy damages a file
(garbage, cut short, emptied), the index or the machine code: the next process computes the right
value with one warning line, the one after it loads the rebuilt entry silently.
"""

from __future__ import annotations

import os
import pathlib
import subprocess
import sys

import pytest

TOY = '''
from rimroll.solver import _jit


def _mul_add(a, b):
    return a * b + 1.0


print(_jit.njit_cached(_mul_add)(2.0, 3.0))
'''


def _run(folder: pathlib.Path) -> subprocess.CompletedProcess:
    env = {**os.environ, "RIMROLL_CACHE_DIR": str(folder / "cache")}
    return subprocess.run([sys.executable, "toy_kernel.py"], cwd=folder, env=env, capture_output=True, text=True,
                          timeout=300)


def _damage(path: pathlib.Path, how: str) -> None:
    data = path.read_bytes()
    if how == "garbage":
        path.write_bytes(bytes((b * 7 + 13) % 256 for b in data))
    elif how == "cut":
        path.write_bytes(data[: len(data) // 2])
    else:
        path.write_bytes(b"")


CASES = [(suffix, how) for suffix in (".nbi", ".nbc") for how in ("garbage", "cut", "emptied")]


@pytest.mark.parametrize("suffix,how", [pytest.param(*c, marks=pytest.mark.slow)
                                        for c in CASES])
def test_a_damaged_cache_entry_is_rebuilt(tmp_path, suffix, how):
    (tmp_path / "toy_kernel.py").write_text(TOY)
    first = _run(tmp_path)
    assert first.returncode == 0 and first.stdout.strip() == "7.0", first.stderr
    (entry,) = (tmp_path / "cache").rglob(f"*{suffix}")
    _damage(entry, how)
    damaged = _run(tmp_path)
    assert damaged.returncode == 0, damaged.stderr
    assert damaged.stdout.strip() == "7.0"
    lines = [line for line in damaged.stderr.splitlines() if line.strip()]
    assert len(lines) == 1 and "damaged" in lines[0] and "rebuilding" in lines[0], damaged.stderr
    again = _run(tmp_path)
    assert again.returncode == 0 and again.stdout.strip() == "7.0" and not again.stderr.strip(), again.stderr
