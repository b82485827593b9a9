"""Benchmark of the CUDA backend on a device: the figures of the GPU issue, in one run.

Run on a machine with a CUDA device and numba-cuda (``rimroll[gpu]``), from the repository root::

    PYTHONPATH=. python benchmarks/gpu.py [--repeat 20] [--big 100] [--out bench_gpu.json]
        [--max-registers 0,128,96] [--block 128,64,256] [--skip-cpu]

It needs only numpy, numba and numba-cuda (no xarray or dask). What it measures, on the Fig. 11
section (beta x omega1 = 240 x 360 states, omega2 = 35, omega3 = 10 1/s; rtol 1e-8, atol 1e-10,
DP5, t_max 20 s):

* compile time of the kernels (rolling only, mu = 1), in this process, separately;
* rolling only: end to end through ``solver.simulate(..., backend="cuda")`` (validation, the
  transfers through pinned buffers, the kernel, the result fields), the device pipeline alone
  (``cuda_backend.run``: host copy into pinned memory, transfers, kernel) and the kernel alone
  (CUDA events, states already on the device); best and median of ``--repeat`` runs after one
  warm-up;
* the same section with mu = 1 (slipping) and its ratio to rolling only;
* ``--big`` times the section's states (default 100: 8.64 M states, the section tiled) through
  ``cuda_backend.run``, in batches as the backend sizes them: trajectories per second, end to
  end and kernel alone;
* the outcomes against the CPU engine on the same states (``--skip-cpu`` to leave that out):
  states whose outcome differs, the largest relative t_end difference where they agree.

Each ``--max-registers`` (0: the compiler's choice) x ``--block`` pair is measured for the rolling
only section; the rest uses the first pair. Results go to stdout and ``--out`` (JSON).
"""

from __future__ import annotations

import argparse
import json
import os
import platform
import statistics
import sys
import time

import numpy as np

from rimroll import solver
from rimroll.solver.engine import backends, kernels
from rimroll.solver.engine.scenes import scene_of
from rimroll.solver.physics.switching import default_tolerances

SECTION = dict(beta=(0.8, 1.8, 240), omega1=(-20.0, 20.0, 360), omega2=35.0, omega3=10.0)
RUN = dict(t_max=20.0, rtol=1e-8, atol=1e-10, method="dp5")
STEPS, SWITCHES = 1_000_000, 10_000


def section_states(nb: int = SECTION["beta"][2], nw: int = SECTION["omega1"][2]) -> np.ndarray:
    b0, b1, _ = SECTION["beta"]
    w0, w1, _ = SECTION["omega1"]
    B, W = np.meshgrid(np.linspace(b0, b1, nb), np.linspace(w0, w1, nw), indexing="ij")
    return np.stack([B, W, np.full_like(B, SECTION["omega2"]), np.full_like(B, SECTION["omega3"])], -1).reshape(-1, 4)


def timed(fn, repeat: int) -> dict:
    fn()  # warm-up (buffers, caches)
    times = []
    for _ in range(repeat):
        t0 = time.perf_counter()
        fn()
        times.append(time.perf_counter() - t0)
    return {"best_ms": 1e3 * min(times), "median_ms": 1e3 * statistics.median(times), "runs": repeat}


def kernel_time(cb, cuda, scene, states: np.ndarray, params, repeat: int) -> dict:
    """Kernel alone (CUDA events), the states and buffers resident on the device."""
    m = states.shape[0]
    k = cb.kernel(scene, RUN["method"])
    d_states = cuda.to_device(np.ascontiguousarray(states))
    d_f = cuda.device_array((m, kernels.N_RF))
    d_i = cuda.device_array((m, kernels.N_RI), dtype=np.int64)
    d_p = cuda.to_device(params.as_array())
    d_sw = cuda.to_device(default_tolerances())
    blocks = -(-m // cb.THREADS_PER_BLOCK)

    def launch():
        k[blocks, cb.THREADS_PER_BLOCK](d_states, m, d_p, RUN["t_max"], RUN["rtol"], RUN["atol"], STEPS, SWITCHES,
                                         d_sw, d_f, d_i)

    launch()
    cuda.synchronize()
    start, stop = cuda.event(), cuda.event()
    times = []
    for _ in range(repeat):
        start.record()
        launch()
        stop.record()
        stop.synchronize()
        times.append(start.elapsed_time(stop))
    return {"best_ms": min(times), "median_ms": statistics.median(times), "runs": repeat}


def device_run(cb, scene, states: np.ndarray, params):
    """cuda_backend.run on the states: (res_f, res_i)."""
    m = states.shape[0]
    res_f = np.empty((m, kernels.N_RF))
    res_i = np.empty((m, kernels.N_RI), dtype=np.int64)
    cb.run(scene, RUN["method"], states, params.as_array(),
           kernels.Limits(RUN["t_max"], RUN["rtol"], RUN["atol"], STEPS, SWITCHES, scene.conservative),
           default_tolerances(), res_f, res_i)
    return res_f, res_i


def agreement(cpu: dict, dev: dict) -> dict:
    differ = cpu["outcome"] != dev["outcome"]
    same = ~differ & (cpu["t_end"] > 0)
    rel = np.abs(dev["t_end"][same] - cpu["t_end"][same]) / cpu["t_end"][same]
    return {"states": int(differ.size), "outcome_differs": int(differ.sum()),
            "outcome_differs_fraction": float(differ.mean()), "t_end_max_rel_diff": float(rel.max(initial=0.0)),
            "status_differs": int((cpu["status"] != dev["status"]).sum())}


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--repeat", type=int, default=20)
    ap.add_argument("--big", type=int, default=100, help="multiple of the section for the throughput run (0: skip)")
    ap.add_argument("--max-registers", default="0", help="comma-separated caps to compare (0: none)")
    ap.add_argument("--block", default="128", help="comma-separated threads per block to compare")
    ap.add_argument("--skip-cpu", action="store_true", help="do not run the CPU engine for the comparison")
    ap.add_argument("--out", default=None, help="write the results as JSON here")
    ap.add_argument("--grid", default="240,360", help="section grid n_beta,n_omega1 (smaller: a smoke test)")
    args = ap.parse_args(argv)

    device = backends.cuda_device()  # one line and exit 1 without the extra or a device
    from numba import cuda, types

    from rimroll.solver.engine import cuda_backend as cb

    caps = [int(v) for v in args.max_registers.split(",")]
    blocks = [int(v) for v in args.block.split(",")]
    states = section_states(*(int(v) for v in args.grid.split(",")))
    rolling, slipping = solver.Params(mu=np.inf), solver.Params(mu=1.0)
    s_roll, s_slip = scene_of(rolling), scene_of(slipping)
    report = {"device": device, "host": platform.node(), "cpu_cores": os.cpu_count(), "section_states": len(states),
              "run": RUN, "numba_cuda": _version("numba-cuda"), "numba": _version("numba"), "configs": []}
    print(f"device: {device}; section: {len(states)} states, {RUN}")

    for cap in caps:
        for tpb in blocks:
            cb.MAX_REGISTERS = cap or None
            cb.THREADS_PER_BLOCK = tpb
            cfg = {"max_registers": cap or None, "threads_per_block": tpb}
            t0 = time.perf_counter()
            cb.compile_kernel(s_roll, RUN["method"])
            cfg["compile_rolling_s"] = time.perf_counter() - t0
            k = cb.kernel(s_roll, RUN["method"])
            sig = types.void(*cb.SIGNATURE)
            # _safe calls the lambda at once, in this iteration
            cfg["registers"] = _safe(lambda: k.get_regs_per_thread(sig))  # noqa: B023
            cfg["local_bytes_per_thread"] = _safe(lambda: k.get_local_mem_per_thread(sig))  # noqa: B023
            cfg["rolling_end_to_end"] = timed(lambda: solver.simulate(states, rolling, **RUN, backend="cuda"),
                                              args.repeat)
            cfg["rolling_device_pipeline"] = timed(lambda: device_run(cb, s_roll, states, rolling), args.repeat)
            cfg["rolling_kernel"] = kernel_time(cb, cuda, s_roll, states, rolling, args.repeat)
            print(f"registers cap {cap or '-'}, block {tpb}: compile {cfg['compile_rolling_s']:.1f} s, "
                  f"{cfg['registers']} registers, {cfg['local_bytes_per_thread']} B local; rolling only: end to end "
                  f"{cfg['rolling_end_to_end']['best_ms']:.2f} ms, "
                  f"pipeline {cfg['rolling_device_pipeline']['best_ms']:.2f} ms, "
                  f"kernel {cfg['rolling_kernel']['best_ms']:.2f} ms (best of {args.repeat})", flush=True)
            report["configs"].append(cfg)
    cb.MAX_REGISTERS = caps[0] or None
    cb.THREADS_PER_BLOCK = blocks[0]

    t0 = time.perf_counter()
    cb.compile_kernel(s_slip, RUN["method"])
    report["compile_slipping_s"] = time.perf_counter() - t0
    report["slipping_end_to_end"] = timed(lambda: solver.simulate(states, slipping, **RUN, backend="cuda"),
                                          max(3, args.repeat // 4))
    report["slipping_kernel"] = kernel_time(cb, cuda, s_slip, states, slipping, max(3, args.repeat // 4))
    first = report["configs"][0]
    report["slipping_over_rolling_end_to_end"] = (report["slipping_end_to_end"]["best_ms"]
                                                  / first["rolling_end_to_end"]["best_ms"])
    print(f"mu = 1: compile {report['compile_slipping_s']:.1f} s; "
          f"end to end {report['slipping_end_to_end']['best_ms']:.2f} ms, "
          f"kernel {report['slipping_kernel']['best_ms']:.2f} ms; "
          f"{report['slipping_over_rolling_end_to_end']:.1f}x rolling only", flush=True)

    if args.big:
        big = np.tile(states, (args.big, 1))
        t0 = time.perf_counter()
        device_run(cb, s_roll, big, rolling)
        wall = time.perf_counter() - t0
        kern = kernel_time(cb, cuda, s_roll, big, rolling, 3)
        report["big"] = {"states": len(big), "end_to_end_s": wall, "end_to_end_per_s": len(big) / wall,
                         "kernel_best_ms": kern["best_ms"], "kernel_per_s": len(big) / (kern["best_ms"] / 1e3),
                         "batch": cb.batch_size(len(big), cuda.current_context().get_memory_info()[0])}
        print(f"{len(big)} states: end to end {wall:.3f} s = {len(big) / wall:.3g} trajectories/s; kernel alone "
              f"{kern['best_ms']:.1f} ms = {report['big']['kernel_per_s']:.3g}/s (batches of {report['big']['batch']})",
              flush=True)

    if not args.skip_cpu:
        for label, params in (("rolling_only", rolling), ("slipping", slipping)):
            t0 = time.perf_counter()
            cpu = solver.simulate(states, params, **RUN)
            cpu_s = time.perf_counter() - t0
            dev = solver.simulate(states, params, **RUN, backend="cuda")
            report[f"agreement_{label}"] = dict(agreement(cpu, dev), cpu_engine_s=cpu_s)
            print(f"{label}: CPU engine {cpu_s:.2f} s on {os.cpu_count()} cores; {report[f'agreement_{label}']}",
                  flush=True)

    if args.out:
        with open(args.out, "w") as f:
            json.dump(report, f, indent=1)
        print(f"wrote {args.out}")
    return 0


def _safe(fn):
    try:
        return fn()
    except Exception:  # noqa: BLE001  an older numba-cuda without the query
        return None


def _version(dist: str) -> str | None:
    from importlib.metadata import PackageNotFoundError, version

    try:
        return version(dist)
    except PackageNotFoundError:
        return None


if __name__ == "__main__":
    try:
        sys.exit(main())
    except backends.BackendUnavailable as exc:
        print(f"benchmark_gpu: {exc}", file=sys.stderr)
        sys.exit(1)
