"""Benchmark of adaptive outcome maps (not a test): the 12 panels of Figs. 11-13, full against adaptive.

    python benchmarks/adaptive_maps.py [--quick] [--repeat 2] [--workers 2] [--out DIR]

For each of fig11, fig12, fig13 runs ``study run NAME`` and ``study run NAME --set adaptive=true``
(alternating, ``--repeat`` times each, ``--force``), and prints per study: the wall time of each
(the median over the repeats: the whole command, imports, derive, plot and file included), the wall
time of the maps alone (the chunks' simulations and refinement, ``study.fanout.run``, plus the boundary
typing by simulation, ``study.assemble.derived_variables``; timed inside the command), the
trajectories simulated for the maps (``n_simulated``, summed over the four scenes, against the
cells), and the cells whose ``outcome`` or ``boundary_type`` differ, per scene.
"""

from __future__ import annotations

import argparse
import pathlib
import subprocess
import sys
import tempfile
import time

import numpy as np
import xarray as xr

STUDIES = ("fig11", "fig12", "fig13")


# `study run` with the maps timed inside it: the chunks (fanout.run) and the derived variables (the boundary
# typing by simulation), printed as one line "MAPS <seconds>" after the command's own output
TIMED = """
import sys, time
from rimroll.study import assemble, cli, fanout
spent = [0.0]
def timed(f):
    def run(*a, **k):
        t = time.perf_counter()
        try:
            return f(*a, **k)
        finally:
            spent[0] += time.perf_counter() - t
    return run
fanout.run = timed(fanout.run)
assemble.derived_variables = timed(assemble.derived_variables)
code = cli.main(sys.argv[1:])
print(f"MAPS {spent[0]:.4f}")
sys.exit(code)
"""


def _run(name: str, out: pathlib.Path, args: list) -> tuple[float, float]:
    """(wall of the whole command [s], wall of its maps [s])."""
    t = time.perf_counter()
    r = subprocess.run([sys.executable, "-c", TIMED, "run", name, "--out", str(out), "--no-progress", "--force",
                        *args], check=True, capture_output=True, text=True)
    wall = time.perf_counter() - t
    maps = float(next(line.split()[1] for line in r.stdout.splitlines() if line.startswith("MAPS ")))
    return wall, maps


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
    totals = np.zeros(6)
    for name in STUDIES:
        walls = {"full": [], "adaptive": []}
        maps = {"full": [], "adaptive": []}
        for _ in range(a.repeat):
            for mode, extra in (("full", []), ("adaptive", ["--set", "adaptive=true"])):
                wall, inner = _run(name, root / mode, [*common, *extra])
                walls[mode].append(wall)
                maps[mode].append(inner)
        full, adapt = (xr.open_dataset(root / mode / f"{name}.nc") for mode in ("full", "adaptive"))
        rows = _differences(full, adapt)
        wf, wa = float(np.median(walls["full"])), float(np.median(walls["adaptive"]))
        mf, ma = float(np.median(maps["full"])), float(np.median(maps["adaptive"]))
        sim, cells = sum(r[3] for r in rows), sum(r[4] for r in rows)
        totals += (wf, wa, sim, cells, mf, ma)
        print(f"{name}: wall full {wf:.1f} s, adaptive {wa:.1f} s ({wa / wf:.0%}); maps alone full {mf:.2f} s, "
              f"adaptive {ma:.2f} s ({ma / mf:.0%}); simulated {sim} of {cells} ({sim / cells:.1%}); walls {walls}")
        for scene, d_out, d_bnd, n_sim, n in rows:
            print(f"  {scene:20s} outcome differences {d_out}, boundary_type differences {d_bnd}, "
                  f"simulated {n_sim} of {n} ({n_sim / n:.1%})")
    print(f"all: wall full {totals[0]:.1f} s, adaptive {totals[1]:.1f} s ({totals[1] / totals[0]:.0%}); maps alone "
          f"full {totals[4]:.1f} s, adaptive {totals[5]:.1f} s ({totals[5] / totals[4]:.0%}); "
          f"simulated {totals[2]:.0f} of {totals[3]:.0f} ({totals[2] / totals[3]:.1%})")


if __name__ == "__main__":
    main()
