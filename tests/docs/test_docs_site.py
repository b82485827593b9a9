"""The documentation site builds with warnings as errors (``mkdocs build --strict``, mkdocs.yml): its four
parts (tutorials, how-to guides, reference, explanation), the reference pages generated from the code's
tables (docs/site_hooks.py), every study's figure, and an API page per public concept from the docstrings
(mkdocstrings), with no Sphinx role left raw."""

from __future__ import annotations

import pathlib
import re
import subprocess
import sys

import pytest

from tests.helpers.paths import ROOT

HOW_TO = ["sweep-and-resume", "cluster", "gpu", "verify", "trace", "adaptive-maps", "continuation", "benchmark"]
API = {  # page: ids of objects it must render
    "study": ["rimroll.study.api.run", "rimroll.study.api.open", "rimroll.study.api.studies"],
    "simulate": ["rimroll.solver.engine.simulate.simulate"],
    "params": ["rimroll.solver.physics.params.Params", "rimroll.solver.physics.params.moment_normalised"],
    "solver": ["rimroll.solver", "rimroll.solver.Params", "rimroll.solver.simulate", "rimroll.solver.invariants"],
    "steady": ["rimroll.solver.analysis.steady.omega20", "rimroll.solver.analysis.steady.stability"],
    "floquet": ["rimroll.solver.analysis.floquet.multipliers"],
    "invariants": ["rimroll.solver.analysis.invariants.invariants"],
    "predictability": ["rimroll.solver.analysis.predictability.basin_entropy",
                       "rimroll.solver.analysis.predictability.make_probability"],
    "rolling": ["rimroll.solver.physics.rolling"],
    "slipping": ["rimroll.solver.physics.slipping"],
    "kinematics": ["rimroll.solver.physics.kinematics"],
    "dataset": ["rimroll.study.dataset.params_of"],
    "registry": ["rimroll.study.registry.Study", "rimroll.study.registry.register"],
    "messages": ["rimroll._messages.LaneStatusWarning"],
}
RAW_ROLE = re.compile(r":(?:func|class|mod|data|meth|attr|exc|obj):(?:<code>|`)")


@pytest.fixture(scope="module")
def site(tmp_path_factory):
    pytest.importorskip("mkdocs")
    pytest.importorskip("mkdocstrings_handlers.python")
    site = tmp_path_factory.mktemp("docs") / "site"
    build = subprocess.run([sys.executable, "-m", "mkdocs", "build", "--strict", "--site-dir", str(site)], cwd=ROOT,
                           capture_output=True, text=True, timeout=300)
    assert build.returncode == 0, build.stdout + build.stderr
    return site


def page(site: pathlib.Path, name: str) -> str:
    return (site / name / "index.html").read_text()


def test_the_navigation_leads_to_every_how_to_and_tutorial(site):
    home = (site / "index.html").read_text()
    for part in ("Tutorials", "How-to guides", "Reference", "Explanation"):
        assert f">{part}<" in home, part  # a section of the navigation
    for name in HOW_TO:
        assert f'href="how-to/{name}/"' in home, name  # in the home page's navigation
        assert (site / "how-to" / name / "index.html").is_file(), name
    for name in ("first-hour", "python", "notebook"):
        assert f'href="tutorials/{name}/"' in home, name


def test_every_api_page_renders_its_objects_without_raw_roles(site):
    for name, ids in API.items():
        html = page(site, f"reference/api/{name}")
        for obj in ids:
            assert f'id="{obj}"' in html, (name, obj)
    raw = {p.relative_to(site).as_posix(): RAW_ROLE.findall(p.read_text()) for p in site.rglob("index.html")}
    assert not {k: v for k, v in raw.items() if v}  # ":func:`run`" is Sphinx's syntax, not the renderer's


def test_the_generated_reference_pages_hold_the_codes_tables(site):
    from rimroll.solver.analysis import boundaries
    from rimroll.solver.engine import outcomes
    from rimroll.study import cli
    from rimroll.study.setting_table import TABLE

    codes = page(site, "reference/codes")
    for table in (outcomes.OUTCOME_MEANINGS, outcomes.STATUS_MEANINGS, outcomes.ON_RIM_REASON_MEANINGS,
                  boundaries.BOUNDARY_MEANINGS):
        for code, meaning in table.items():
            assert f"<td>{int(code)}</td>\n<td><code>{meaning.split(':')[0]}</code></td>" in codes, meaning
    settings = page(site, "reference/settings")
    physical = [name for name, s in TABLE.items() if s.physical]
    assert physical and all(f"<code>{name}</code>" in settings for name in physical)
    command_line = page(site, "reference/command-line")
    parser = cli._parser()
    commands = next(a for a in parser._actions if hasattr(a, "choices") and a.choices and "run" in a.choices).choices
    for name in commands:
        assert f"<code>study {name}</code>" in command_line, name


def test_every_study_has_its_section_and_figure(site):
    from rimroll.study import registry

    studies = page(site, "studies")
    for name in registry.names():
        assert f"figures/studies/{name}.png" in studies, name
        assert (site / "figures" / "studies" / f"{name}.png").is_file(), name
    readings = page(site, "explanation/paper-readings")
    assert "The energy (60), and the split of Prop. 6, have rho where the paper prints r" in readings
