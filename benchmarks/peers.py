"""Peer benchmark: the Fig. 11 rolling section through heyoka and through rimroll, compared at matched error.

    pip install -e ".[bench]"          # heyoka, the optional extra
    python benchmarks/peers.py [--out bench_results] [--rounds 5] [--no-cold]

What runs (benchmarks/README.md says how to read the output):

* the section: 360 x 240 states (beta in [0.8, 1.8] rad, omega1 in [-20, 20] 1/s), omega2 = 35 1/s,
  omega3 = 10 1/s, Params(mu=inf), t_max = 20 s;
* heyoka (``rimroll.peer_models.heyoka_rolling``): batch mode at ``heyoka.recommended_simd_size()``,
  terminal events whose callbacks refill the lane, one forked process per core, tol = --heyoka-tols;
* rimroll: ``rimroll.solver.simulate`` (one thread per core), method dp5 at --dp5-rtols and dop853 at
  --dop853-rtols, atol = rtol / 100;
* rimroll's exact reduced solver (``simulate(method="reduced")``, issue 40: root isolation and quadrature on
  the level of (60), (68), no time integration): one row (its "tol" is the rtol that only sets what counts as
  a transversal omega1 zero), unless --no-reduced.

heyoka is optional: without it (``pip install -e ".[bench]"``) the heyoka rows are left out and said so.

Before timing, the heyoka model's rates and F2 are checked against rimroll's physics at a few hundred
states (1e-12 relative; the script stops if they differ). Every configuration is then run once untimed
(compiled or loaded from the caches), and timed in --rounds rounds that alternate: round k runs each
configuration once, heyoka and rimroll interleaved (odd rounds in reverse order); the best round counts.
Errors: median and max |t_end - truth| over 200 states that fall after integration, sampled with seed 0
from rimroll's dop853 rtol 1e-12 answer; the truth is rimroll's scipy reference (solve_ivp DOP853, rtol
1e-12, atol 1e-14, ``solver.analysis.scipy_reference``), computed once and cached in --out. Times at matched
median error 1e-9 and 1e-12: log-log interpolation between the two tolerances whose errors bracket it.
Outcome agreement: every configuration's outcome on all 86,400 cells against rimroll dop853 at rtol 1e-12.
Cold compile (unless --no-cold): CPU time in a fresh process with an empty cache (peers_cold.py).
Writes ``peers.json`` and ``peers.md`` to --out and prints a one-paragraph summary.
"""

from __future__ import annotations

import argparse
import datetime
import json
import os
import pathlib
import platform
import subprocess
import sys
import time

import numpy as np
import peers_report

from rimroll import solver
from rimroll.peer_models import heyoka_rolling
from rimroll.solver.analysis import scipy_reference as reference
from rimroll.study.outcome_sections import SETTINGS, section_axes

HERE = pathlib.Path(__file__).resolve().parent
OMEGA2, T_MAX = 35.0, 20.0
REFERENCE = ("rimroll", "dop853", 1e-12)
"""The configuration every outcome is compared with (docs/work-precision.md: the reference of the study)."""
N_TRUTH, TRUTH_SEED, TRUTH_RTOL, TRUTH_ATOL = 200, 0, 1e-12, 1e-14
TARGETS = (1e-9, 1e-12)
HEYOKA_TOLS = (1e-4, 1e-5, 1e-6, 1e-7, 1e-8, 1e-9, 1e-10, 1e-11, 1e-12)
DP5_RTOLS = (1e-6, 1e-7, 1e-8, 1e-9, 1e-10, 1e-11)
DOP853_RTOLS = (1e-6, 1e-7, 1e-8, 1e-9, 1e-10, 1e-11, 1e-12)
REDUCED = ("rimroll", "reduced", 1e-8)


def section() -> np.ndarray:
    """The Fig. 11 section's initial states (86,400, 4), beta-major (the grid of the fig11 study)."""
    _, beta, omega1 = section_axes(SETTINGS)
    b, w = np.meshgrid(beta.values, omega1.values, indexing="ij")
    return np.stack([b, w, np.full_like(b, OMEGA2), np.full_like(b, SETTINGS["omega3"])], -1).reshape(-1, 4)


def load_now() -> dict:
    up = subprocess.run(["uptime"], capture_output=True, text=True).stdout.strip()
    return {"uptime": up, "loadavg": [round(v, 2) for v in os.getloadavg()],
            "time": datetime.datetime.now().isoformat(timespec="seconds")}


class Engines:
    """The configurations and how to run each one: (engine, method, tol) -> result dict."""

    def __init__(self, x, params, args):
        self.x, self.params = x, params
        self.configs = interleaved([[("heyoka", "taylor", t) for t in args.heyoka_tols],
                                    [("rimroll", "dp5", t) for t in args.dp5_rtols],
                                    [("rimroll", "dop853", t) for t in args.dop853_rtols]])
        if REFERENCE not in self.configs:
            self.configs.append(REFERENCE)
        if args.reduced:
            self.configs.append(REDUCED)
        self.integrators = {}
        for engine, _, tol in self.configs:
            if engine == "heyoka":
                start = time.process_time()
                self.integrators[tol] = heyoka_rolling.Integrator(params, tol)
                self.integrators[tol].build_cpu_s = time.process_time() - start
        self.workers = heyoka_rolling.Workers(x, self.integrators.values(), args.workers)

    def run(self, config) -> tuple[dict, float, float]:
        """(result, wall seconds, CPU seconds of this process and the heyoka workers)."""
        engine, method, tol = config
        wall, cpu = time.perf_counter(), time.process_time()
        if engine == "heyoka":
            res = heyoka_rolling.classify(self.x, self.integrators[tol], T_MAX, self.workers)
        else:
            res = solver.simulate(self.x, self.params, t_max=T_MAX, rtol=tol, atol=tol / 100, method=method,
                                  workers=self.workers.n)  # method "reduced": atol is not used
        wall, cpu = time.perf_counter() - wall, time.process_time() - cpu
        return res, wall, cpu + res.get("worker_cpu_s", 0.0)

    def close(self):
        self.workers.__exit__()


def interleaved(lists) -> list:
    """The items of several lists taken in turn (a, b, c, a, b, c, ...)."""
    out = []
    for k in range(max(len(v) for v in lists)):
        out += [v[k] for v in lists if k < len(v)]
    return out


def truth(x, params, ref: dict, out: pathlib.Path) -> dict:
    """The sample of falling states and their reference t_end (cached in ``out``; recomputed when the
    sample or the settings change)."""
    candidates = np.nonzero((ref["outcome"] <= 1) & (ref["t_end"] > 0))[0]
    idx = np.sort(np.random.default_rng(TRUTH_SEED).choice(candidates, N_TRUTH, replace=False))
    key = json.dumps({"params": params.as_dict(), "t_max": T_MAX, "rtol": TRUTH_RTOL, "atol": TRUTH_ATOL,
                      "method": "DOP853", "states": x[idx].round(15).tolist()}, sort_keys=True)
    path = out / "truth_fig11_falls.npz"
    if path.exists():
        cached = np.load(path)
        if str(cached["key"]) == key:
            return {"idx": idx, "t_end": cached["t_end"], "outcome": cached["outcome"], "cached": True,
                    "seconds": float(cached["seconds"])}
    start = time.perf_counter()
    res = reference.reference(x[idx], params, t_max=T_MAX, rtol=TRUTH_RTOL, atol=TRUTH_ATOL, method="DOP853")
    seconds = time.perf_counter() - start
    np.savez(path, key=key, t_end=res["t_end"], outcome=res["outcome"], seconds=seconds)
    return {"idx": idx, "t_end": res["t_end"], "outcome": res["outcome"], "cached": False, "seconds": seconds}


def cold_compile(args) -> list[dict]:
    """Cold compile of each engine, one fresh process per item (peers_cold.py prints one JSON line)."""
    jobs = ([["heyoka", f"{t:g}"] for t in args.heyoka_tols] + [["rimroll", m] for m in ("dp5", "dop853")]
            + ([["rimroll", "reduced"]] if args.reduced else []))
    rows = []
    for job in jobs:
        done = subprocess.run([sys.executable, str(HERE / "peers_cold.py"), *job], capture_output=True, text=True)
        if done.returncode:
            rows.append({"engine": job[0], "setting": job[1], "error": done.stderr.strip().splitlines()[-1:]})
        else:
            rows.append(json.loads(done.stdout.strip().splitlines()[-1]))
        print(f"  cold compile {job}: {rows[-1]}", flush=True)
    return rows


def rows_of(engines, last, times, cpus, sample) -> list[dict]:
    """One row per configuration: best times, errors on the sample, outcome agreement with REFERENCE."""
    ref_outcome = last[REFERENCE]["outcome"]
    rows = []
    for config in engines.configs:
        engine, method, tol = config
        res = last[config]
        err = np.abs(np.asarray(res["t_end"])[sample["idx"]] - sample["t_end"])
        outcome = np.asarray(res["outcome"])
        row = {"engine": engine, "method": method, "tol": tol, "wall_best_s": min(times[config]),
               "wall_median_s": float(np.median(times[config])), "wall_s": [round(t, 4) for t in times[config]],
               "cpu_best_s": min(cpus[config]), "err_median_s": float(np.median(err)), "err_max_s": float(err.max()),
               "outcome_differs_from_reference": int(np.sum(outcome != ref_outcome)),
               "outcome_wrong_in_sample": int(np.sum(outcome[sample["idx"]] != sample["outcome"])),
               "counts": np.bincount(outcome, minlength=5).tolist()}
        if engine == "heyoka":
            ig = engines.integrators[tol]
            row.update(order=ig.order, batch=ig.batch, processes=engines.workers.n, lane_steps=res["steps"],
                       events=res["events"], build_s_warm=ig.build_cpu_s)
        else:
            row.update(steps=int(res["n_steps"].sum()), searched=int(res["n_searched"].sum()),
                       threads=engines.workers.n)
        rows.append(row)
    return rows


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", type=pathlib.Path, default=pathlib.Path("bench_results"),
                        help="folder for peers.json, peers.md and the cached truth (default bench_results/)")
    parser.add_argument("--rounds", type=int, default=5, help="alternating timed rounds; the best counts")
    parser.add_argument("--workers", type=int, default=None, help="processes (heyoka) and threads (rimroll); "
                        "default one per core")
    parser.add_argument("--heyoka-tols", type=float, nargs="+", default=HEYOKA_TOLS)
    parser.add_argument("--dp5-rtols", type=float, nargs="+", default=DP5_RTOLS)
    parser.add_argument("--dop853-rtols", type=float, nargs="+", default=DOP853_RTOLS)
    parser.add_argument("--no-cold", action="store_true", help="skip the cold-compile measurements")
    parser.add_argument("--no-reduced", dest="reduced", action="store_false",
                        help="leave out the exact reduced solver's row")
    args = parser.parse_args(argv)
    if not heyoka_rolling.available():
        print("heyoka is not installed (pip install -e '.[bench]'): its rows are left out", file=sys.stderr)
        args.heyoka_tols = ()
    args.out.mkdir(parents=True, exist_ok=True)
    meta = {"load_before": load_now(), "rounds": args.rounds, "cores": os.cpu_count(), "machine": platform.machine(),
            "python": platform.python_version(), "versions": versions(), "section": "Fig. 11: 360 x 240 states, "
            f"omega2 = {OMEGA2}, omega3 = {SETTINGS['omega3']}, mu = inf, t_max = {T_MAX} s"}
    x, params = section(), solver.Params(mu=float("inf"))

    if args.heyoka_tols:
        print("checking the heyoka model against rimroll's physics ...", flush=True)
        meta["model_check"] = heyoka_rolling.check_against_rimroll(params)  # raises if it differs
    engines = Engines(x, params, args)
    try:
        print(f"{len(engines.configs)} configurations; warm-up run of each (compiles or loads rimroll's kernels)",
              flush=True)
        last = {config: engines.run(config)[0] for config in engines.configs}
        sample = truth(x, params, last[REFERENCE], args.out)
        times = {config: [] for config in engines.configs}
        cpus = {config: [] for config in engines.configs}
        for k in range(args.rounds):
            for config in engines.configs if k % 2 == 0 else engines.configs[::-1]:
                last[config], wall, cpu = engines.run(config)
                times[config].append(wall)
                cpus[config].append(cpu)
            print(f"round {k + 1}/{args.rounds} done", flush=True)
    finally:
        engines.close()
    meta["load_after"] = load_now()
    rows = rows_of(engines, last, times, cpus, sample)
    meta["truth"] = {"n": N_TRUTH, "seed": TRUTH_SEED, "method": "solver.analysis.scipy_reference, scipy DOP853",
                     "rtol": TRUTH_RTOL, "atol": TRUTH_ATOL, "cached": sample["cached"],
                     "seconds": round(sample["seconds"], 2),
                     "fall_in": int(np.sum(sample["outcome"] == 0)), "fall_out": int(np.sum(sample["outcome"] == 1))}
    cold = [] if args.no_cold else cold_compile(args)
    result = {"meta": meta, "rows": rows, "matched": peers_report.matched(rows, TARGETS), "cold_compile": cold}
    (args.out / "peers.json").write_text(json.dumps(result, indent=1))
    (args.out / "peers.md").write_text(peers_report.markdown(result))
    print(peers_report.summary(result))
    print(f"wrote {args.out / 'peers.json'} and {args.out / 'peers.md'}")
    return 0


def versions() -> dict:
    import numba

    import rimroll

    commit = subprocess.run(["git", "-C", str(HERE), "rev-parse", "--short", "HEAD"], capture_output=True, text=True)
    out = {"rimroll": rimroll.__version__, "rimroll_commit": commit.stdout.strip() or None,
           "numba": numba.__version__, "numpy": np.__version__, "heyoka": None}
    if heyoka_rolling.available():
        import heyoka

        out.update(heyoka=heyoka.__version__, simd_size=heyoka.recommended_simd_size())
    return out


if __name__ == "__main__":
    sys.exit(main())
