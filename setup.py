"""Build hook: record the git revision of the source tree in the built package.

``pip install .`` (non-editable) copies the packages into site-packages, where git can no longer
tell which commit they came from. ``build_py`` therefore writes ``rimroll/study/_build_info.json``
(``git_revision``, with ``-dirty`` when tracked files differed from it; absent outside a git
checkout) into the build, and ``rimroll.study.dataset.git_revision`` reads it. Everything else about the
package is declared in pyproject.toml.
"""

import json
import os
import subprocess

from setuptools import setup
from setuptools.command.build_py import build_py

HERE = os.path.dirname(os.path.abspath(__file__))


def _git(*args):
    try:
        return subprocess.run(["git", *args], cwd=HERE, capture_output=True, text=True, timeout=10,
                              check=True).stdout.strip()
    except (OSError, subprocess.SubprocessError):
        return None


class BuildPyWithRevision(build_py):
    """``build_py`` plus ``rimroll/study/_build_info.json`` holding the source tree's git revision."""

    def run(self):
        super().run()
        rev = _git("rev-parse", "HEAD")
        info = {"git_revision": None}
        if rev:
            dirty = _git("status", "--porcelain", "--untracked-files=no")
            info["git_revision"] = f"{rev}-dirty" if dirty else rev
        target = os.path.join(self.build_lib, "rimroll", "study", "_build_info.json")
        if not self.dry_run and os.path.isdir(os.path.dirname(target)):
            with open(target, "w") as fh:
                json.dump(info, fh)


setup(cmdclass={"build_py": BuildPyWithRevision})
