"""The repository documents itself: every study and output in docs/, no citation of a design
document a user of the repository does not have, and CF flags that cf_xarray understands."""

from __future__ import annotations

import ast
import pathlib
import re

import pytest

from rimroll.study import registry
from tests.helpers.paths import ROOT

USER_FACING = [ROOT / "README.md", *sorted((ROOT / "docs").rglob("*.md")), *sorted((ROOT / "docs").rglob("*.part")),
               *sorted((ROOT / "study").glob("*.py")),
               *sorted((ROOT / "workflows").glob("*.py"))]
DESIGN_CITATION = re.compile(r"DESIGN\s*(§|\(?\d)")


@pytest.mark.parametrize("path", USER_FACING, ids=lambda p: p.relative_to(ROOT).as_posix())
def test_no_citation_of_the_internal_design_document(path):
    hits = [line for line in path.read_text().splitlines() if DESIGN_CITATION.search(line)]
    assert not hits, hits


def test_long_names_cite_docs_or_the_paper_only():
    for name in registry.names():
        for var in registry.get(name).variables:
            assert "DESIGN" not in var.long_name, (name, var.name)


def test_every_study_and_variable_is_documented():
    text = (ROOT / "docs" / "studies.md").read_text()
    sections = dict(re.findall(r"^## `([^`]+)`: .*?\n(.*?)(?=^## |\Z)", text, re.M | re.S))
    # rimroll's own studies (a test's probe study, registered in this process, is no study of rimroll's)
    names = [name for name in registry.names() if registry.get(name).compute.__module__.startswith("rimroll.")]
    assert set(sections) == set(names), "run python docs/gen_studies.py"
    for name in names:
        for var in registry.get(name).variables:
            assert f"| `{var.name}` | {var.units} |" in sections[name], (name, var.name)


def _generated_pages() -> set[pathlib.Path]:
    """The pages docs/site_hooks.py generates when the site is built (its ``GENERATED``), read without
    importing mkdocs."""
    tree = ast.parse((ROOT / "docs" / "site_hooks.py").read_text())
    value = next(node.value for node in tree.body if isinstance(node, ast.Assign) and node.targets[0].id == "GENERATED")
    return {(ROOT / "docs" / name).resolve() for name in ast.literal_eval(value)}


def test_docs_links_resolve():
    generated = _generated_pages()
    # a .part is read into a generated page of the same folder (reference/command-line-intro.part)
    for path in [ROOT / "README.md", *(ROOT / "docs").rglob("*.md"), *(ROOT / "docs").rglob("*.part")]:
        for target in re.findall(r"\]\(([^)#]+)(?:#[^)]*)?\)", path.read_text()):
            if "://" not in target:
                resolved = (path.parent / target).resolve()
                assert resolved.exists() or resolved in generated, (path.name, target)
