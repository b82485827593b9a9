"""Every code block the README and the documentation site show a user runs as written.

Each page's bash and Python blocks run in order in an empty directory (bash with ``study`` on PATH,
Python in one namespace), after a short set-up that makes the result files the page reads. A block
that needs a cluster, a GPU or an install is marked in the page, just before it, with an HTML comment
``<!-- skip: REASON -->`` (invisible on the site) and is skipped with that reason. The pages whose
blocks run for minutes are marked slow (``pytest -m slow tests/docs/test_docs_blocks.py``). "Your first
hour" and "Where rimroll reads the paper" are run, with what they print, by tests/docs/test_readme.py.
"""

from __future__ import annotations

import ast
import dataclasses
import logging
import pathlib
import re
import subprocess

import pytest

from tests.helpers.paths import ROOT
from tests.helpers.shell import user_shell

DOCS = ROOT / "docs"
FENCE = re.compile(r"(?:<!-- skip: (?P<reason>[^>]+?) -->\s*\n)?^```(?P<lang>\w*)\n(?P<code>.*?)^```", re.M | re.S)
RUN_LANGUAGES = ("bash", "python")


@dataclasses.dataclass(frozen=True)
class Page:
    """How a page's blocks run: ``setup`` (bash) makes the files it reads, ``prelude`` (Python) names
    what a snippet takes as given (the ``ds`` it is about); ``slow`` for minutes of work."""

    setup: str = ""
    prelude: str = ""
    slow: bool = False


# every page with a block to run; tests/docs/test_readme.py runs these two, with what they print
RUN_ELSEWHERE = {"tutorials/first-hour.md", "explanation/paper-readings.md"}
PAGES = {
    "README.md": Page(),
    "tutorials/python.md": Page(),
    "reference/files.md": Page(setup="study run fig8 --quick\n"
                                     "study run fig12 --quick --set omega2=60 --out a\n"
                                     "study run fig12 --quick --set omega2=70 --out b\n", slow=True),
    "reference/command-line-intro.part": Page(setup="study run realisable-cube --quick\n", slow=True),
    "outcome-studies.md": Page(setup="study run fig12 --quick\n",
                               prelude="import xarray as xr\nds = xr.open_dataset('results/fig12.nc')\n", slow=True),
    "work-precision.md": Page(setup="study run work-precision --quick\n", slow=True),
    "solution-types.md": Page(slow=True),
    "how-to/sweep-and-resume.md": Page(slow=True),  # a cube of 3 x 19 x 5 settings: minutes
    "how-to/verify.md": Page(setup="study run fig11 --quick\n", slow=True),
    "how-to/trace.md": Page(setup="study run fig12 --quick\n", slow=True),
    "how-to/adaptive-maps.md": Page(slow=True),
    "how-to/continuation.md": Page(slow=True),
    "how-to/benchmark.md": Page(slow=True),
    "explanation/dissipation-models.md": Page(slow=True),
    "explanation/predictability.md": Page(slow=True),
    "explanation/exact-rolling.md": Page(),  # compiles the reduced solver's kernel (~6.5 s CPU)
    "shot-api.md": Page(),
    "shots.md": Page(slow=True),  # shot maps and traces; a capture compiles the rim engine's hybrid scene
    "explanation/shot-questions.md": Page(slow=True),  # three --quick shot studies: about 30 s warm
}


def page_blocks(name: str) -> list[tuple[str, str, str | None]]:
    """(language, code, skip reason or None) of every bash or Python block of a page, in order."""
    path = ROOT / name if name == "README.md" else DOCS / name
    text = path.read_text()
    if name == "README.md":  # its first two blocks, install and test, are checked against CI by test_readme
        text = text[text.index("\n## "):]
    return [(m["lang"], m["code"], m["reason"]) for m in FENCE.finditer(text) if m["lang"] in RUN_LANGUAGES]


def all_pages() -> list[str]:
    pages = ["README.md"] + [p.relative_to(DOCS).as_posix() for p in sorted(DOCS.rglob("*.md"))]
    return pages + [p.relative_to(DOCS).as_posix() for p in sorted(DOCS.rglob("*.part"))]


def test_every_shown_block_is_run_or_skipped_with_its_reason():
    for name in all_pages():
        code = page_blocks(name)
        unmarked = [c for _, c, reason in code if reason is None]
        if unmarked:
            assert name in PAGES or name in RUN_ELSEWHERE, f"{name}: its blocks run in no test"
        for _, _, reason in code:
            assert reason is None or len(reason.split()) >= 3, (name, reason)  # a reason, not a bare word
    skipped = {name for name in all_pages() for _, _, reason in page_blocks(name) if reason}
    assert {"how-to/cluster.md", "how-to/gpu.md"} <= skipped  # the blocks no test machine can run


def test_the_solver_names_its_public_api_literally():
    """``rimroll.solver.__all__`` is a literal list (read without importing, as the API reference
    does) and names exactly the names it loads on first use."""
    tree = ast.parse((ROOT / "solver" / "__init__.py").read_text())
    assigned = {t.id: node.value for node in tree.body if isinstance(node, ast.Assign) for t in node.targets}
    names = ast.literal_eval(assigned["__all__"])
    public = {k.value for k in assigned["_PUBLIC"].keys}
    assert sorted(names) == sorted(public)
    import rimroll.solver

    assert all(getattr(rimroll.solver, name) is not None for name in names)


def _run_page(name: str, tmp_path: pathlib.Path, monkeypatch) -> dict:
    page = PAGES[name]
    work, env = user_shell(tmp_path, links=("tests", "benchmarks", "docs"))  # the scripts a how-to runs
    monkeypatch.chdir(work)
    monkeypatch.setenv("MPLBACKEND", "Agg")

    def bash(text: str) -> None:
        run = subprocess.run(["bash", "-euo", "pipefail", "-c", text], cwd=work, env=env,
                             capture_output=True, text=True, timeout=3600)
        assert run.returncode == 0, f"{name}:\n{text}\n{run.stdout[-3000:]}\n{run.stderr[-3000:]}"

    if page.setup:
        bash(page.setup)
    namespace: dict = {}
    rimroll_logger = logging.getLogger("rimroll")
    level = rimroll_logger.level  # a page may silence rimroll's notices, as a user would: for this page only
    try:
        if page.prelude:
            exec(compile(page.prelude, "prelude", "exec"), namespace)
        for lang, text, reason in page_blocks(name):
            if reason is not None:
                continue
            if lang == "bash":
                bash(text)
            else:
                exec(compile(text, name, "exec"), namespace)
    finally:
        rimroll_logger.setLevel(level)
    return namespace


DEFAULT = [name for name, page in PAGES.items() if not page.slow]
SLOW = [name for name, page in PAGES.items() if page.slow]


def test_the_readme_quick_example_runs_and_shows_what_it_says(tmp_path, monkeypatch):
    ns = _run_page("README.md", tmp_path, monkeypatch)
    share = ns["periodic"].sel(scene="rolling_only").mean().item()
    assert 0 < share < 0.2  # the periodic island of Fig. 11: a few percent of the section
    assert ns["ds"].sizes["scene"] == 4 and float(ns["ds"]["omega2"]) == 65.0
    assert ns["res"]["outcome"].shape == (2,) and set(ns["res"]["outcome"].tolist()) <= {0, 1, 2, 3, 4}


@pytest.mark.parametrize("name", [n for n in DEFAULT if n != "README.md"])
def test_the_blocks_of_a_page_run(name, tmp_path, monkeypatch):
    _run_page(name, tmp_path, monkeypatch)


@pytest.mark.slow
@pytest.mark.parametrize("name", SLOW)
def test_the_blocks_of_a_long_page_run(name, tmp_path, monkeypatch):
    _run_page(name, tmp_path, monkeypatch)


SKIPPED = [(name, i, reason) for name in all_pages() for i, (_, _, reason) in enumerate(page_blocks(name)) if reason]


@pytest.mark.parametrize("name, index, reason", SKIPPED, ids=[f"{n}-{i}" for n, i, _ in SKIPPED])
def test_a_block_that_needs_what_the_test_machine_lacks(name, index, reason):
    """Reported as skipped with the page's own reason (``-rs``)."""
    pytest.skip(f"{name}, block {index + 1}: {reason}")
