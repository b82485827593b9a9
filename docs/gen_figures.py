"""Draw docs/figures/studies/<name>.png, the figure of every study on its --quick grid, for
docs/studies.md and the documentation site.

Run from the repository root after a study or its plot changes: ``python docs/gen_figures.py [NAME ...]``
(about 2 min on 2 cores once the kernels are compiled), then ``python docs/gen_studies.py``.
"""

import pathlib
import sys
import tempfile

ROOT = pathlib.Path(__file__).resolve().parent.parent
OUT = ROOT / "docs" / "figures" / "studies"
DPI = 80  # small files: the site shows them at page width


def main(names=None) -> None:
    import rimroll
    from rimroll.study import io, registry

    OUT.mkdir(parents=True, exist_ok=True)
    for name in names or registry.names():
        study = registry.get(name)
        if study.plot is None:
            continue
        with tempfile.TemporaryDirectory() as tmp:
            with rimroll.run(name, quick=True, out=tmp, progress=False) as ds:
                path = io.write_figure(study.plot(ds), OUT / f"{name}.png", dpi=DPI)
        print(f"wrote {path.relative_to(ROOT)} ({path.stat().st_size / 1024:.0f} KiB)")


if __name__ == "__main__":
    main(sys.argv[1:] or None)
