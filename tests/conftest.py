"""Shared fixtures: quick runs of the steady studies, made once per test session; the probe study."""

from __future__ import annotations

import os
import re
import sys

import pytest

from tests.helpers.paths import HELPERS

STEADY_STUDIES = ("fig3", "fig5", "fig6", "fig7", "fig8")


@pytest.fixture(scope="session")
def quick_results(tmp_path_factory):
    """Directory holding ``--quick`` runs (.nc and .png) of every steady study."""
    from rimroll.study.cli import main

    out = tmp_path_factory.mktemp("results")
    for name in STEADY_STUDIES:
        assert main(["run", name, "--quick", "--out", str(out), "--no-progress"]) == 0
    return out


PROBE = HELPERS / "fanout_probe.py"


@pytest.fixture
def probe_study(monkeypatch):
    """The test-only ``fanout-probe`` study (tests/helpers/fanout_probe.py), registered in this process for the
    test only: afterwards the registry again holds rimroll's own studies (tests/docs/test_docs.py)."""
    from rimroll.study import registry

    monkeypatch.setenv(registry.PLUGIN_ENV, str(PROBE))
    monkeypatch.delenv("FANOUT_PROBE_FAIL_MU", raising=False)
    yield registry.get("fanout-probe")
    registry._REGISTRY.pop("fanout-probe", None)
    sys.modules.pop("rimroll_plugin_" + re.sub(r"\W", "_", os.path.abspath(PROBE)), None)


@pytest.fixture
def probe(probe_study):
    """``probe_study`` under its short name."""
    return probe_study


@pytest.fixture(scope="module")
def fig8_file(tmp_path_factory):
    """A ``fig8 --quick`` result, made once per test module (tests copy it before they damage it)."""
    from rimroll.study.cli import main

    out = tmp_path_factory.mktemp("fig8")
    assert main(["run", "fig8", "--quick", "--out", str(out), "--no-progress"]) == 0
    return out / "fig8.nc"
