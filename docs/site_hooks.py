"""mkdocs hooks (mkdocs.yml ``hooks``): pages made from README.md and docs/notebook.ipynb, so that each
text is written once. A page is a list of README sections (by their ``## `` or ``### `` title); links
into ``docs/`` are made relative to the site, links to other files of the repository become code."""

from __future__ import annotations

import json
import pathlib
import re

from mkdocs.structure.files import File

ROOT = pathlib.Path(__file__).resolve().parent.parent
PAGES = {
    "index.md": ("rimroll", ["What it is", "Documentation", "Units"], True),
    "getting-started.md": ("Getting started", ["Your first hour", "In a notebook: `rimroll.run`", "Studies",
                                               "Sweeps, clusters and resuming", "Python API"], True),
    "paper-readings.md": ("Where rimroll reads the paper", ["Where rimroll reads the paper"], False),
    "files.md": ("Files: xarray, netCDF and CF", ["Results in xarray", "Reference slices and `study verify`"], False),
    "clusters.md": ("On a cluster", ["On a cluster"], False),
}
HEADING = re.compile(r"^(#{2,3}) (.+)$", re.M)
LINK = re.compile(r"(!?)\[([^\]]*)\]\(([^)\s]+)\)")


def sections(text: str) -> dict[str, str]:
    """Each ``##``/``###`` section of ``text`` by its title, up to the next heading of its level or above."""
    heads = [(m.start(), len(m.group(1)), m.group(2).strip()) for m in HEADING.finditer(text)]
    out = {}
    for i, (start, level, title) in enumerate(heads):
        end = next((s for s, lv, _ in heads[i + 1:] if lv <= level), len(text))
        body = text[start:end].split("\n", 1)[1] if "\n" in text[start:end] else ""
        out[title] = body
    return out


def relink(text: str) -> str:
    """README links as site links: ``docs/x.md`` -> ``x.md``; a file outside docs/ -> its name as code."""
    def one(m: re.Match) -> str:
        bang, label, target = m.groups()
        if "://" in target or target.startswith("#"):
            return m.group(0)
        path, _, anchor = target.partition("#")
        if path.startswith("docs/"):
            return f"{bang}[{label}]({path[5:]}{'#' + anchor if anchor else ''})"
        return f"`{path}`" if not label or label == path else f"{label} (`{path}`)"
    return LINK.sub(one, text)


def readme_page(title: str, titles: list[str], head: bool) -> str:
    readme = (ROOT / "README.md").read_text()
    found = sections(readme)
    parts = [f"# {title}\n"]
    if head:  # the install and test commands at the top of the README
        parts.append(readme.split("\n## ", 1)[0].split("\n", 1)[1])
    for name in titles:
        level = "##" if name != title else None
        if level:
            parts.append(f"\n## {name}\n")
        parts.append(found[name])
    return relink("\n".join(parts))


def notebook_page() -> str:
    """docs/notebook.ipynb as a page: its markdown cells and its code, a link to the notebook."""
    nb = json.loads((ROOT / "docs" / "notebook.ipynb").read_text())
    out = []
    for cell in nb["cells"]:
        source = "".join(cell["source"])
        out.append(source if cell["cell_type"] == "markdown" else f"```python\n{source}\n```")
    out.insert(1, "Download the notebook: [notebook.ipynb](notebook.ipynb).")
    return "\n\n".join(out) + "\n"


def on_files(files, config):
    for name, (title, titles, head) in PAGES.items():
        files.append(File.generated(config, name, content=readme_page(title, titles, head)))
    files.append(File.generated(config, "notebook.md", content=notebook_page()))
    return files
