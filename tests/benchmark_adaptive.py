"""Benchmark of adaptive outcome maps (not a test): the 12 panels of Figs. 11-13, full against adaptive.

    python tests/benchmark_adaptive.py [--quick] [--repeat 2] [--workers 2] [--out DIR]

For each of fig11, fig12, fig13 runs ``study run NAME`` and ``study run NAME --set adaptive=true``
(alternating, ``--repeat`` times each, ``--force``), and prints per study: the wall time of each
(the median over the repeats: the whole command, imports, derive, plot and file included), the
trajectories simulated for the maps (``n_simulated``, summed over the four scenes, against the
cells), and the cells whose ``outcome`` or ``boundary_type`` differ, per scene.
"""

from __future__ import annotations

import argparse
import pathlib
import shutil
import subprocess
import sys
import tempfile
import time

import numpy as np
import xarray as xr

STUDIES = ("fig11", "fig12", "fig13")


def _run(name: str, out: pathlib.Path, args: list) -> float:
    study = shutil.which("study") or str(pathlib.Path(sys.executable).with_name("study"))
    t = time.perf_counter()
    subprocess.run([study, "run", name, "--out", str(out), "--no-progress", "--force", *args], check=True,
                   stdout=subprocess.DEVNULL)
    return time.perf_counter() - t


def _differences(full: xr.Dataset, adapt: xr.Dataset) -> list:
    rows = []
    for scene in full["scene"].values:
        a, b = full.sel(scene=scene), adapt.sel(scene=scene)
        rows.append((str(scene), int((a["outcome"] != b["outcome"]).sum()),
                     int((a["boundary_type"] != b["boundary_type"]).sum()), int(b["n_simulated"]),
                     int(a["outcome"].size)))
    return rows


def main(argv=None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--quick", action="store_true")
    ap.add_argument("--repeat", type=int, default=2)
    ap.add_argument("--workers", type=int, default=2)
    ap.add_argument("--out", default=None)
    a = ap.parse_args(argv)
    root = pathlib.Path(a.out or tempfile.mkdtemp(prefix="adaptive-bench-"))
    common = ["--workers", str(a.workers)] + (["--quick"] if a.quick else [])
    totals = np.zeros(4)
    for name in STUDIES:
        walls = {"full": [], "adaptive": []}
        for _ in range(a.repeat):
            walls["full"].append(_run(name, root / "full", common))
            walls["adaptive"].append(_run(name, root / "adaptive", [*common, "--set", "adaptive=true"]))
        full, adapt = (xr.open_dataset(root / mode / f"{name}.nc") for mode in ("full", "adaptive"))
        rows = _differences(full, adapt)
        wf, wa = float(np.median(walls["full"])), float(np.median(walls["adaptive"]))
        sim, cells = sum(r[3] for r in rows), sum(r[4] for r in rows)
        totals += (wf, wa, sim, cells)
        print(f"{name}: wall full {wf:.1f} s, adaptive {wa:.1f} s ({wa / wf:.0%}); simulated {sim} of {cells} "
              f"({sim / cells:.1%}); walls {walls}")
        for scene, d_out, d_bnd, n_sim, n in rows:
            print(f"  {scene:20s} outcome differences {d_out}, boundary_type differences {d_bnd}, "
                  f"simulated {n_sim} of {n} ({n_sim / n:.1%})")
    print(f"all: wall full {totals[0]:.1f} s, adaptive {totals[1]:.1f} s ({totals[1] / totals[0]:.0%}); "
          f"simulated {totals[2]:.0f} of {totals[3]:.0f} ({totals[2] / totals[3]:.1%})")


if __name__ == "__main__":
    main()
