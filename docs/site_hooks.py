"""mkdocs hooks (mkdocs.yml ``hooks``): the reference pages generated from the code's own tables, so
that they cannot fall behind it, and the notebook as a page. The other pages are plain files in docs/.

Generated, at build time: ``reference/settings.md`` (``rimroll.study.setting_table``, through
``docs/gen_studies.py``), ``reference/command-line.md`` (the ``study`` command's parser),
``reference/codes.md`` (the outcome, status, on-rim, boundary and solution-type codes) and
``tutorials/notebook.md`` (``docs/notebook.ipynb``)."""

from __future__ import annotations

import argparse
import json
import os
import pathlib
import sys

from mkdocs.structure.files import File

DOCS = pathlib.Path(__file__).resolve().parent
GENERATED = ("reference/settings.md", "reference/command-line.md", "reference/codes.md", "tutorials/notebook.md")


def settings_page() -> str:
    """Every setting of rimroll's studies and every physical parameter: units, meaning, allowed values."""
    sys.path.insert(0, str(DOCS))
    try:
        import gen_studies
    finally:
        sys.path.remove(str(DOCS))
    from rimroll.study import registry
    from rimroll.study.registry import natural_order

    studies = [registry.get(name) for name in natural_order(registry.names())]
    table = gen_studies.settings_table(studies)
    return ("# Settings\n\nChange a setting with `study run NAME --set KEY=VALUE` (a list `a,b,c` or a range "
            "`start:stop:num` sweeps it where the study allows) or `rimroll.run(NAME, KEY=VALUE)`. Each study's "
            "defaults are in [the studies](../studies.md) and `study info NAME`.\n\n"
            "(This page is generated from `study/setting_table.py` when the site is built.)\n\n"
            + "\n".join(table[1:]) + "\n")


def _help(parser: argparse.ArgumentParser) -> str:
    return "```text\n" + parser.format_help().rstrip() + "\n```\n"


def command_line_page() -> str:
    """``study --help`` and the help of each subcommand, as the parser prints them, after the overview."""
    from rimroll.study import cli

    os.environ["COLUMNS"] = "100"  # argparse wraps at the terminal's width: a fixed one for the page
    parser = cli._parser()
    parts = ["# The command line: `study`\n", (DOCS / "reference" / "command-line-intro.part").read_text(),
             "\n## `study`\n", _help(parser)]
    sub = next(a for a in parser._actions if isinstance(a, argparse._SubParsersAction))
    for name, command in sub.choices.items():
        parts += [f"\n## `study {name}`\n", _help(command)]
    parts.append("\n(The help texts on this page are generated from the parser, `study/cli.py`, when the site is "
                 "built.)\n")
    return "\n".join(parts)


def _codes(title: str, where: str, meanings: dict) -> list[str]:
    lines = [f"\n## {title}\n", f"From `{where}`.\n", "| code | flag | meaning |", "|---|---|---|"]
    for code, text in meanings.items():
        flag, _, meaning = text.partition(":")
        lines.append(f"| {int(code)} | `{flag.strip()}` | {meaning.strip().replace('|', chr(92) + '|')} |")
    return lines


def codes_page() -> str:
    """The integer codes of rimroll's categorical outputs, with their CF flag names and meanings."""
    from rimroll.solver.analysis import boundaries, solution_types
    from rimroll.solver.engine import outcomes

    lines = ["# Codes: outcome, status, on the rim, boundary, solution type\n",
             "Every categorical output is an int8 code. Files carry the same table as CF `flag_values` and "
             "`flag_meanings` (cf_xarray reads them: `ds.outcome.cf == \"periodic_rolling\"`). How each outcome is "
             "decided: [the outcome rules](../outcome-studies.md#rules-of-a-simulation) and "
             "[the outcome engine](../outcome-engine.md). (This page is generated from the tables below when the "
             "site is built.)"]
    lines += _codes("`outcome`", "solver.OUTCOME_MEANINGS", outcomes.OUTCOME_MEANINGS)
    lines += _codes("`status`", "solver.STATUS_MEANINGS", outcomes.STATUS_MEANINGS)
    lines += _codes("`on_rim_reason`", "solver.engine.outcomes.ON_RIM_REASON_MEANINGS", outcomes.ON_RIM_REASON_MEANINGS)
    lines += _codes("`boundary_type`", "solver.analysis.boundaries.BOUNDARY_MEANINGS", boundaries.BOUNDARY_MEANINGS)
    lines += _codes("`solution_type`", "solver.analysis.solution_types.TYPE_MEANINGS", solution_types.TYPE_MEANINGS)
    return "\n".join(lines) + "\n"


def notebook_page() -> str:
    """docs/notebook.ipynb as a page: its markdown cells and its code, a link to the notebook."""
    nb = json.loads((DOCS / "notebook.ipynb").read_text())
    out = []
    for cell in nb["cells"]:
        source = "".join(cell["source"])
        out.append(source if cell["cell_type"] == "markdown" else f"```python\n{source}\n```")
    out.insert(1, "Download the notebook: [notebook.ipynb](../notebook.ipynb). The test suite runs it in a Jupyter "
                  "kernel (`tests/docs/test_notebook.py`); run it yourself to see the outputs and the figures.")
    return "\n\n".join(out) + "\n"


def on_files(files, config):
    pages = dict(zip(GENERATED, (settings_page(), command_line_page(), codes_page(), notebook_page())))
    for name, content in pages.items():
        files.append(File.generated(config, name, content=content))
    return files
