"""Benchmark of the fan-out (not a test): speed-up of 2 workers over 1, dask overhead, peak memory.

    python benchmarks/fanout.py [--quick]

1. Speed-up and overhead: ``outcome-cube --quick`` on a finer section (compute-heavy, numba
   kernels release the GIL), run with 1 and with 2 local workers. Overhead = wall time of the
   fan-out (submit .. last part written) over the sum of the per-chunk compute times divided by
   the workers, minus 1. Assembly is timed apart.
2. Peak memory: ``fig3`` (omega20, float64) on a (beta0, omega30) grid re-gridded with
   ``--set beta0=start:stop:num`` to two sizes 10x apart, each run in a fresh process; the peak
   RSS of that process (``ru_maxrss``) of the fan-out and assembly (not the plot: fig3's picture loads its whole
   plane by design) against the cube's size in bytes.

The figures are ratios measured in one run on a shared machine: read them as such.
"""

from __future__ import annotations

import argparse
import json
import os
import resource
import subprocess
import sys
import tempfile
import time


def fanout_once(name, sets, workers, out, quick=True):
    from rimroll.study import cli_text, fanout, registry
    from rimroll.study.assemble import assemble
    from rimroll.study.dataset import global_attrs
    from rimroll.study.parts import PartStore
    from rimroll.study.plan import make_plan
    from rimroll.study.progress import ProgressLine

    plan = make_plan(registry.get(name), quick, cli_text.setting_values(registry.get(name), sets))
    store = PartStore(out, name, plan.fingerprint)
    with fanout.client(workers) as c, store.lock():
        stats = fanout.run(plan, store, list(range(plan.n_chunks)), c, ProgressLine(1, name, enabled=False))
        t0 = time.perf_counter()
        assemble(plan, store, os.path.join(out, f"{name}.nc"), global_attrs(registry.get(name), plan.params,
                                                                             plan.settings, "bench"))
        stats.assemble_s = time.perf_counter() - t0
        store.remove()
    return plan, stats


def speed(quick: bool):
    grid = ["--set", "n_beta=16", "--set", "n_omega1=24"] if quick else ["--set", "n_beta=24", "--set", "n_omega1=40"]
    sets = [s for s in grid if s != "--set"]
    fanout_once("outcome-cube", sets + ["mu=1", "k_r=0", "k_d=0", "omega2=65"], 1, tempfile.mkdtemp())  # warm up
    rows = {}
    for workers in (1, 2):
        plan, st = fanout_once("outcome-cube", sets, workers, tempfile.mkdtemp())
        rows[workers] = st
        print(f"outcome-cube {plan.shape} = {plan.n_chunks} chunks, {workers} worker(s): wall {st.wall_s:.2f} s, "
              f"sum of chunk compute {st.compute_s:.2f} s, overhead {st.wall_s * workers / st.compute_s - 1:+.1%}, "
              f"assembly {st.assemble_s:.2f} s", flush=True)
    print(f"speed-up 2 workers vs 1: {rows[1].wall_s / rows[2].wall_s:.2f}x "
          f"(per-chunk compute grew {rows[2].compute_s / rows[1].compute_s:.2f}x: >1 means the cores were shared)")
    # the default chunk of realisable-cube: one whole 721 x 560 plane per task
    sets = ["n_beta0=721", "n_omega30=560"] + (["v_throw=3,10", "j=0.6667"] if quick else [])
    plan, st = fanout_once("realisable-cube", sets, 1, tempfile.mkdtemp())
    print(f"realisable-cube {plan.shape} = {plan.n_chunks} chunks, 1 worker: wall {st.wall_s:.2f} s, sum of chunk "
          f"compute {st.compute_s:.2f} s, overhead {st.wall_s / st.compute_s - 1:+.1%}, assembly {st.assemble_s:.2f} s")


def peak_rss_child(n_beta0: int) -> None:
    out = tempfile.mkdtemp()
    t0 = time.perf_counter()
    plan, st = fanout_once("fig3", [f"beta0=-3.1:3.1:{n_beta0}", "n_omega30=5000"], 2, out, quick=False)
    size = os.path.getsize(os.path.join(out, "fig3.nc"))
    print(json.dumps({"cube_bytes": n_beta0 * 5000 * 8, "file_bytes": size, "wall_s": time.perf_counter() - t0,
                      "chunks": plan.n_chunks,
                      "maxrss_mib": resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024}))


def memory(quick: bool):
    for n_beta0 in ((500, 5000) if quick else (2000, 20000)):
        run = subprocess.run([sys.executable, __file__, "--rss-child", str(n_beta0)],
                             capture_output=True, text=True, check=True)
        r = json.loads(run.stdout.strip().splitlines()[-1])
        print(f"fig3 over {n_beta0} x 5000 (beta0 x omega30): cube {r['cube_bytes'] / 2**20:.0f} MiB (float64), "
              f"{r['chunks']} chunks, peak RSS {r['maxrss_mib']:.0f} MiB, wall {r['wall_s']:.1f} s", flush=True)


if __name__ == "__main__":
    ap = argparse.ArgumentParser()
    ap.add_argument("--quick", action="store_true")
    ap.add_argument("--rss-child", type=int)
    args = ap.parse_args()
    if args.rss_child:
        peak_rss_child(args.rss_child)
    else:
        speed(args.quick)
        memory(args.quick)
