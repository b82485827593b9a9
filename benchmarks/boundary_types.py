"""Benchmark of the refined boundary types (not a test): what ``boundary_type`` adds to an outcome study.

    python benchmarks/boundary_types.py [--full] [--study fig12]

Measures, in one run on the same grid (the study's settings; ``--quick`` grid unless ``--full``):

1. the study's ``compute``: ``solver.simulate`` of the four scenes (all cores);
2. its ``derive`` with the boundary pairs of the conservative scenes refined by simulation
   (``solver.analysis.boundaries.refine_grid``: bisection, band samples and a golden-section search, all
   pairs batched per stage), and the grid-only ``classify`` it replaces;

and prints the seconds, the simulated states and the ratio derive / compute, which is what
the refinement adds to ``study run``.
"""

from __future__ import annotations

import argparse
import os
import time
from concurrent.futures import ThreadPoolExecutor

import numpy as np
import xarray as xr

from rimroll.solver import Params, simulate
from rimroll.solver.analysis import boundaries
from rimroll.study.dataset import coords_of, global_attrs, params_of
from rimroll.study.derived_variables import derived_variables
from rimroll.study.plan import compute_chunk, make_plan
from rimroll.study.registry import get


def _dataset(name: str, full: bool) -> tuple[xr.Dataset, float]:
    """The study's grid computed in memory (no files, no derived variables) and the seconds it took."""
    study = get(name)
    plan = make_plan(study, quick=not full)
    arrays = {v.name: np.empty(plan.shape, dtype=v.dtype) for v in study.variables}
    for params in (Params(mu=np.inf), Params(mu=1.0), Params(mu=1.0, k_d=0.02)):  # compile (or load) each scene first
        simulate([1.2, 0.0, 65.0, 10.0], params, t_max=0.1, workers=1)
    t0 = time.perf_counter()
    with ThreadPoolExecutor(max_workers=os.cpu_count()) as pool:
        for k, part in enumerate(pool.map(lambda k: compute_chunk(plan.job(k)), range(plan.n_chunks))):
            for v in study.variables:
                arrays[v.name][plan.region(k)] = part[v.name]
    seconds = time.perf_counter() - t0
    dims = [a.name for a in plan.axes]
    data = {v.name: (dims, arrays[v.name], v.attrs) for v in study.variables}
    attrs = global_attrs(study, plan.params, plan.settings, "benchmarks/boundary_types.py")
    return xr.Dataset(data, coords=coords_of(plan.axes), attrs=attrs), seconds


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--full", action="store_true", help="the default 240 x 360 grid instead of --quick")
    ap.add_argument("--study", default="fig12", choices=["fig11", "fig12", "fig13"])
    args = ap.parse_args()
    ds, t_compute = _dataset(args.study, args.full)
    study = get(args.study)
    t0 = time.perf_counter()
    derived = derived_variables(study, ds)
    t_derive = time.perf_counter() - t0
    p = params_of(ds)
    dims = ("scene", "beta", "omega1")
    t0 = time.perf_counter()
    outcome = ds["outcome"].transpose(*dims).values
    grid = boundaries.classify(*(ds[n].transpose(*dims).values for n in ("outcome", "f2_min", "half_period", "t_end")),
                               p.m * p.g, rolling_outcome=np.broadcast_to(outcome[0], outcome.shape))
    t_grid = time.perf_counter() - t0
    lab = derived["boundary_type"][1]
    print(f"{args.study} {'full' if args.full else 'quick'} grid {dict(ds.sizes)}")
    print(f"compute (simulate, 4 scenes): {t_compute:.2f} s, {int(ds['n_steps'].sum()):,} steps")
    print(f"derive (refined boundary types + former_periodic): {t_derive:.2f} s = {t_derive / t_compute:.3f} x compute")
    print(f"grid-only classify: {t_grid:.4f} s")
    for k, scene in enumerate(ds["scene"].values):
        print(f"  {scene:20s} cells per type (refined) {np.bincount(lab[k].ravel(), minlength=6).tolist()}, "
              f"grid-only {np.bincount(grid[k].ravel(), minlength=6).tolist()}")


if __name__ == "__main__":
    main()
