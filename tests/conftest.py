"""Shared fixtures: quick runs of the steady studies, made once per test session."""

from __future__ import annotations

import pytest

STEADY_STUDIES = ("fig3", "fig5", "fig6", "fig7", "fig8")


@pytest.fixture(scope="session")
def quick_results(tmp_path_factory):
    """Directory holding ``--quick`` runs (.nc and .png) of every steady study."""
    from rimroll.study.cli import main

    out = tmp_path_factory.mktemp("results")
    for name in STEADY_STUDIES:
        assert main(["run", name, "--quick", "--out", str(out), "--no-progress"]) == 0
    return out
