"""The README works as written: its install blocks match CI; the tutorial "Your first hour" and the
explanation "Where rimroll reads the paper" run and print what they say."""

from __future__ import annotations

import re
import subprocess

import numpy as np

from tests.helpers.paths import ROOT
from tests.helpers.shell import user_shell

README = (ROOT / "README.md").read_text()
FIRST_HOUR = ROOT / "docs" / "tutorials" / "first-hour.md"
PAPER_READINGS = ROOT / "docs" / "explanation" / "paper-readings.md"
FENCE = re.compile(r"^```(\w*)\n(.*?)^```", re.M | re.S)


def blocks(text: str) -> list[tuple[str, str]]:
    """(language, code) of every fenced block of ``text``, in order."""
    return [(m.group(1), m.group(2)) for m in FENCE.finditer(text)]


def _commands(code: str) -> list[str]:
    return [line.split("  #")[0].strip() for line in code.splitlines() if line.strip() and not line.startswith("#")]


def test_readme_starts_with_the_install_block_and_the_test_block():
    head = README[: README.index("\n## ")]
    first, second = blocks(head)
    assert len(blocks(head)) == 2 and first[0] == second[0] == "bash"
    install = " ".join(_commands(first[1]))
    for step in ("python3 -m venv .venv", ". .venv/bin/activate", "pip install .", "study run fig8 --quick"):
        assert step in install  # a virtual environment: system pip refuses to install (PEP 668)
    assert install.index("python3 -m venv .venv") < install.index("pip install .") < install.index("study run")
    # ruff, then the import contract (docs/architecture.md), then the tests, with the reasons of the skipped ones
    assert _commands(second[1]) == ['. .venv/bin/activate && pip install ".[test]" && ruff check . && lint-imports'
                                    ' && python -m pytest -q -rs']


def test_the_readme_is_short_and_points_to_the_site():
    """The README is the front page (at most 10 KB and 150 lines); the manual is the site, each of
    whose four parts it links."""
    assert len(README.encode()) <= 10_000 and README.count("\n") <= 150
    for page in ("docs/tutorials/first-hour.md", "docs/how-to/cluster.md", "docs/studies.md",
                 "docs/outcome-studies.md", "docs/contributing.md"):
        assert f"]({page})" in README, page


def test_ci_runs_exactly_the_readme_test_command():
    ci = [line.strip() for line in (ROOT / ".ci" / "run").read_text().splitlines()
          if line.strip() and not line.startswith("#")]
    test_command = _commands(blocks(README[: README.index("\n## ")])[1][1])[0]
    assert ci[-1] == test_command  # the last thing CI does is the README's command, verbatim
    assert "python3 -m venv .venv" in ci  # the README's environment, made from this checkout's files
    assert not any("pip install" in line for line in ci[:-1])  # nothing installed outside the README's way


def test_your_first_hour_runs_as_written(tmp_path, monkeypatch):
    """Every block of the tutorial "Your first hour", in order, in an empty directory: bash with
    ``study`` on PATH (this checkout), Python in one namespace, as a user pasting them would."""
    code = blocks(FIRST_HOUR.read_text())
    assert [lang for lang, _ in code].count("python") >= 4 and [lang for lang, _ in code].count("bash") >= 3
    work, env = user_shell(tmp_path)
    monkeypatch.chdir(work)
    monkeypatch.setenv("MPLBACKEND", "Agg")
    namespace: dict = {}
    for lang, text in code:
        if lang == "bash":
            run = subprocess.run(["bash", "-euo", "pipefail", "-c", text], cwd=work, env=env,
                                 capture_output=True, text=True, timeout=900)
            assert run.returncode == 0, f"{text}\n{run.stdout}\n{run.stderr}"
        else:
            exec(compile(text, str(FIRST_HOUR), "exec"), namespace)
    # what the snippets say they show
    assert (work / "results" / "fig11.nc").is_file() and (work / "results" / "t_end_by_scene.png").is_file()
    ds = namespace["ds"]
    assert list(ds["scene"].values) == ["rolling_only", "slipping", "drilling", "rolling_resistance"]
    periodic = namespace["periodic"]
    assert int(periodic.sel(scene="rolling_only")) > 0 and int(periodic.sel(scene="drilling")) == 0
    assert float(namespace["changed"]) < 0.05
    scored = namespace["scored"]
    assert scored.dims == ("mu",) and np.allclose(scored["mu"], [0.25, 0.5, 1.0, 2.0])
    assert ((scored >= 0) & (scored <= 1)).all()


def test_where_rimroll_reads_the_paper_runs_and_prints_what_it_says(capsys):
    """The Python blocks of "Where rimroll reads the paper", in order, in one namespace; what they
    print is what the page's comments say."""
    text = PAPER_READINGS.read_text()
    code = [c for lang, c in blocks(text) if lang == "python"]
    assert len(code) == 2
    namespace: dict = {}
    for c in code:
        exec(compile(c, str(PAPER_READINGS), "exec"), namespace)
    printed = capsys.readouterr().out.splitlines()
    comments = [line.split("#", 1)[1].strip() for c in code for line in c.splitlines() if line.startswith("print(")]
    energy, split, printed_split, *steady_lines = printed
    assert comments[0].startswith(energy)  # "3e-11, 3e-03 over 5 s"
    assert comments[1].startswith(split) and split == "True False"
    assert comments[2].startswith(printed_split) and printed_split == "0.923 True"
    assert [f"# {line}" for line in steady_lines] == [line for line in code[1].splitlines() if line.startswith("# ")]
