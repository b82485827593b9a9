"""Cost of a make-probability: per shot and per estimate of 10^4 draws, on ``--workers`` cores (not a test).

    python benchmarks/shot_probability.py [--workers 2] [--rounds 3] [--draws 10000] [--out bench_results]

The workload is one nominal free throw of the ``shot-probability`` study (7.2 m/s, 55 degree, 3 Hz
backspin, 4.19 m from the hoop's axis, 0.92 m below the rim, the paper's ring, the solver's default
contact) under the study's default release noise (speed SD 0.08 m/s, angle SD 1.3 degree, backspin
SD 3 1/s, aim SD 0.5 degree), ``--draws`` noisy shots, in vacuum and with air drag (rho_air = 1.2
kg/m^3). The draws are split into ``--workers`` equal blocks run on as many threads (the shot loop's
kernels release the GIL or not: the report says which by the speed-up), best of ``--rounds`` after
a warm-up (vacuum: on 1 and on ``--workers`` threads; drag, whose flight is integrated: one round on
``--workers`` threads). It reports seconds per estimate, microseconds per shot (wall, and the process's CPU time: on a
shared machine the wall time is an upper bound), shots per second and the
estimate itself with its Wilson interval (so a faster run that changes the answer is seen), and the
machine's load (``os.getloadavg``) before and after. Times are never asserted: compare numbers of
one run. Writes ``shot_probability.json`` into ``--out`` (default ``bench_results/``, ignored by git).
"""

from __future__ import annotations

import argparse
import json
import os
import pathlib
import time
from concurrent.futures import ThreadPoolExecutor

import numpy as np

from rimroll import solver
from rimroll.solver import shots
from rimroll.workflows import shot_probability as sp


def estimate(settings: dict, params, workers: int) -> tuple[float, dict]:
    """Wall time [s] of one make-probability estimate of ``settings['draws']`` draws on ``workers``
    threads, and its counts (the draws of the study: ``noise_draws`` of the seed, split in blocks)."""
    n = int(settings["draws"])
    releases = sp.noisy_releases(settings, np.array(float(settings["speed"])), np.array(float(settings["angle"])))
    blocks = np.array_split(np.arange(n), workers)

    geometry = str(settings["geometry"])
    rim, contact = sp.rim_params(params, geometry), sp.contact_of(settings)
    budget = dict(t_max=float(settings["t_max_shot"]), max_impacts=int(settings["max_impacts"]))

    def run(idx):
        part = {k: (v[idx] if np.ndim(v) else v) for k, v in releases.items()}
        return shots.simulate_shots(part, rim, contact, geometry=geometry, **budget)["outcome"]
    t0, c0 = time.perf_counter(), time.process_time()
    with ThreadPoolExecutor(workers) as pool:
        outcome = np.concatenate(list(pool.map(run, blocks)))
    wall, cpu = time.perf_counter() - t0, time.process_time() - c0
    counts = sp.make_counts(outcome)
    return wall, {**sp.probability_fields(counts, n, float(settings["confidence"])), "cpu": cpu}


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--workers", type=int, default=2)
    ap.add_argument("--rounds", type=int, default=3)
    ap.add_argument("--draws", type=int, default=10_000)
    ap.add_argument("--out", default="bench_results")
    a = ap.parse_args()
    if a.workers < 1 or a.rounds < 1 or a.draws < a.workers:
        raise SystemExit("benchmark: --workers and --rounds must be >= 1 and --draws >= --workers")
    settings = {**sp.SENS_SETTINGS, "draws": a.draws}
    load_before = os.getloadavg()
    rows = []
    for label, params in (("vacuum", solver.Params()), ("drag", solver.Params(rho_air=1.2))):
        estimate({**settings, "draws": max(a.workers, 50)}, params, a.workers)  # warm: compiles once
        # drag: the flight is integrated (about 10 x the vacuum shot): one round on --workers threads only
        for workers in (sorted({1, a.workers}) if label == "vacuum" else [a.workers]):
            walls, cpus = [], []
            for _ in range(a.rounds if label == "vacuum" else 1):
                wall, fields = estimate(settings, params, workers)
                walls.append(wall)
                cpus.append(fields["cpu"])
            best = min(walls)
            rows.append({"air": label, "workers": workers, "draws": a.draws, "seconds_per_estimate": best,
                         "us_per_shot": 1e6 * best / a.draws, "shots_per_second": a.draws / best,
                         "p_make": float(fields["p_make"]), "p_make_lower": float(fields["p_make_lower"]),
                         "p_make_upper": float(fields["p_make_upper"]), "walls": walls,
                         "cpu_seconds": min(cpus), "cpu_us_per_shot": 1e6 * min(cpus) / a.draws})
    report = {"release": {k: settings[k] for k in ("speed", "angle", "backspin", "distance", "height")},
              "noise": {k: settings[k] for k in sp.NOISE}, "load_before": load_before,
              "load_after": os.getloadavg(), "cpus": os.cpu_count(), "rows": rows}
    out = pathlib.Path(a.out)
    out.mkdir(parents=True, exist_ok=True)
    (out / "shot_probability.json").write_text(json.dumps(report, indent=1))
    print(f"load average before {load_before[0]:.2f}, after {report['load_after'][0]:.2f} ({os.cpu_count()} cpus)")
    print("| air | threads | s per estimate (10^4 draws) | us per shot | CPU us per shot | shots/s | "
          "P(make) [Wilson 95 %] |")
    print("|---|---|---|---|---|---|---|")
    for r in rows:
        print(f"| {r['air']} | {r['workers']} | {r['seconds_per_estimate'] * 1e4 / r['draws']:.2f} | "
              f"{r['us_per_shot']:.0f} | {r['cpu_us_per_shot']:.0f} | {r['shots_per_second']:.0f} | {r['p_make']:.3f} "
              f"[{r['p_make_lower']:.3f}, {r['p_make_upper']:.3f}] |")


if __name__ == "__main__":
    main()
