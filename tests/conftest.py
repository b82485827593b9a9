"""Shared fixtures: quick runs of the steady studies, made once per test session."""

from __future__ import annotations

import os
import pathlib
import re
import sys

import pytest

ROOT = pathlib.Path(__file__).resolve().parent.parent
STEADY_STUDIES = ("fig3", "fig5", "fig6", "fig7", "fig8")


@pytest.fixture(scope="session")
def quick_results(tmp_path_factory):
    """Directory holding ``--quick`` runs (.nc and .png) of every steady study."""
    from rimroll.study.cli import main

    out = tmp_path_factory.mktemp("results")
    for name in STEADY_STUDIES:
        assert main(["run", name, "--quick", "--out", str(out), "--no-progress"]) == 0
    return out


PROBE = pathlib.Path(__file__).with_name("fanout_probe.py")


@pytest.fixture
def probe_study(monkeypatch):
    """The test-only ``fanout-probe`` study (tests/fanout_probe.py), registered in this process for the
    test only: afterwards the registry again holds rimroll's own studies (tests/test_docs.py)."""
    from rimroll.study import registry

    monkeypatch.setenv(registry.PLUGIN_ENV, str(PROBE))
    monkeypatch.delenv("FANOUT_PROBE_FAIL_MU", raising=False)
    yield registry.get("fanout-probe")
    registry._REGISTRY.pop("fanout-probe", None)
    sys.modules.pop("rimroll_plugin_" + re.sub(r"\W", "_", os.path.abspath(PROBE)), None)


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
