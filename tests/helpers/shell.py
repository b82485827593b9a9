"""A user's shell for the tests that run what a page or the README shows: ``study`` on PATH, an empty folder."""

from __future__ import annotations

import os
import pathlib
import sys

from tests.helpers.paths import ROOT


def user_shell(tmp_path: pathlib.Path, links=()) -> tuple[pathlib.Path, dict]:
    """An empty working directory ``tmp_path/work`` and the environment of a user's shell in it: ``study`` on
    PATH (this checkout's, through the running Python), the Agg plotting backend, and the checkout's folders
    ``links`` (e.g. ``"tests"``, ``"docs"``) linked into it for the scripts a page runs."""
    bin_dir = tmp_path / "bin"
    bin_dir.mkdir()
    shim = bin_dir / "study"
    shim.write_text(f'#!/bin/sh\nexec "{sys.executable}" -m rimroll.study "$@"\n')
    shim.chmod(0o755)
    work = tmp_path / "work"
    work.mkdir()
    for folder in links:
        (work / folder).symlink_to(ROOT / folder)
    env = dict(os.environ, PATH=f"{bin_dir}{os.pathsep}{os.path.dirname(sys.executable)}{os.pathsep}"
               f"{os.environ['PATH']}", MPLBACKEND="Agg")
    return work, env
