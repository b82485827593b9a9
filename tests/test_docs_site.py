"""The documentation site builds with warnings as errors (``mkdocs build --strict``, mkdocs.yml): every
page, the pages made from README.md and docs/notebook.ipynb (docs/site_hooks.py), every study's figure,
and the API reference from the docstrings (mkdocstrings)."""

from __future__ import annotations

import pathlib
import subprocess
import sys

import pytest

ROOT = pathlib.Path(__file__).resolve().parent.parent


def test_the_site_builds_with_warnings_as_errors(tmp_path):
    pytest.importorskip("mkdocs")
    pytest.importorskip("mkdocstrings_handlers.python")
    site = tmp_path / "site"
    build = subprocess.run([sys.executable, "-m", "mkdocs", "build", "--strict", "--site-dir", str(site)], cwd=ROOT,
                           capture_output=True, text=True, timeout=300)
    assert build.returncode == 0, build.stdout + build.stderr
    pages = {p.parent.name for p in site.glob("*/index.html")}
    assert {"getting-started", "notebook", "studies", "paper-readings", "clusters", "files", "api"} <= pages
    api = (site / "api" / "index.html").read_text()
    for name in ("rimroll.study.api.run", "rimroll.study.api.open", "rimroll.solver.engine.simulate.simulate",
                 "rimroll._messages.LaneStatusWarning"):
        assert f'id="{name}"' in api, name
    studies = (site / "studies" / "index.html").read_text()
    from rimroll.study import registry

    for name in registry.names():
        assert f"figures/studies/{name}.png" in studies, name
        assert (site / "figures" / "studies" / f"{name}.png").is_file(), name
    readings = (site / "paper-readings" / "index.html").read_text()
    assert "The energy (60), and the split of Prop. 6, have rho where the paper prints r" in readings
