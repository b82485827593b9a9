"""The ``shot`` map at full size: 200 x 200 shots (speed x angle), with and without air drag (not a test).

    python benchmarks/shots.py [--workers 2] [--rounds 2] [--n 200] [--out bench_results]

The workload is the ``shot`` study's default grid (release speed 6.5-7.9 m/s x angle 40-65 degree,
a free throw: 4.19 m from the hoop's axis, 0.92 m below the rim, no spin, the paper's ring, the
solver's default contact), run by the study layer as ``study run shot`` runs it (dask, ``--workers``
local threads), once in vacuum and once with air drag (``rho_air = 1.2`` kg/m^3, C_D = 0.5). It
reports:

* the cold compile apart: a fresh process with an empty kernel cache simulating one shot in vacuum,
  then one in air (the compile and cache write of the flight kernel, ``physics.shot_air``) [s];
* the warm wall time of each map, best of ``--rounds`` [s], and shots per second;
* where the shots spend their simulated time: flight and on the rim (the solver's per-shot
  ``t_end`` and ``time_on_rim``), the impacts per shot (``n_impacts``), and the outcome shares;
* where the computer spends its time: a ``--profile-n`` map (default 60 x 60) on one thread under
  cProfile, the shares of the shot loop's flight and contact search, impacts and rolling on the rim
  (the engine), and the rest.

It writes ``shots.json`` and each map (``vacuum/shot.nc``, ``drag/shot.nc`` with their figures) into
``--out`` (default ``bench_results/``, ignored by git) and prints one table. Times are never asserted:
the machine is shared; compare numbers of one run.
"""

from __future__ import annotations

import argparse
import json
import os
import pathlib
import subprocess
import sys
import tempfile
import time

import numpy as np

COLD = """
import time
t0 = time.perf_counter()
from rimroll.solver import Params, shots
t1 = time.perf_counter()
shots.simulate_shots({"speed": 7.2, "angle": 0.9}, Params(), shots.Contact(), max_impacts=0)
t2 = time.perf_counter()
shots.simulate_shots({"speed": 7.2, "angle": 0.9}, Params(rho_air=1.2), shots.Contact(), max_impacts=0)
t3 = time.perf_counter()
print(t1 - t0, t2 - t1, t3 - t2)
"""


def cold_compile() -> tuple[float, float, float]:
    """(import [s], first vacuum shot [s], first shot in air [s]: the flight kernel's compile) in a fresh
    process with an empty kernel cache (no impact: the rim engine's scene kernels are not compiled)."""
    with tempfile.TemporaryDirectory() as cache:
        env = {**os.environ, "RIMROLL_CACHE_DIR": cache}
        out = subprocess.run([sys.executable, "-c", COLD], env=env, capture_output=True, text=True, check=True)
    imported, first, air = (float(v) for v in out.stdout.split()[-3:])
    return imported, first, air


def one_map(n: int, workers: int, rho_air: float, keep=None) -> tuple[float, dict]:
    """Wall time [s] of an n x n ``shot`` map and what its shots did; ``keep``: a folder to write the
    map into (``shot.nc`` and its figure ``shot.png``, drawn after the timing)."""
    import rimroll

    start = time.perf_counter()
    ds = rimroll.run("shot", workers=workers, progress=False, n_speed=n, n_angle=n, rho_air=rho_air,
                     out=keep, force=keep is not None)
    wall = time.perf_counter() - start
    from rimroll.solver import shots

    names = list(shots.OUTCOME_MEANINGS)
    outcome = ds["outcome"].values.ravel()
    t_end, on_rim = ds["t_end"].values.ravel(), ds["time_on_rim"].values.ravel()
    stats = {
        "shots": int(outcome.size),
        "shots_per_s": outcome.size / wall,
        "simulated_time_s": float(t_end.sum()),
        "share_flight": float(1.0 - on_rim.sum() / t_end.sum()),
        "share_on_rim": float(on_rim.sum() / t_end.sum()),
        "impacts_per_shot": float(ds["n_impacts"].values.mean()),
        "max_impacts": int(ds["n_impacts"].values.max()),
        "outcomes": {names[c]: float(np.mean(outcome == c)) for c in np.unique(outcome)},
    }
    if keep is not None:
        from rimroll.study import io, registry

        io.write_figure(registry.get("shot").plot(ds), pathlib.Path(keep) / "shot.png")
    return wall, stats


PHASES = {  # (file, function) of the shot loop whose cumulative time is each phase's
    "flight and contact search": (("shot_loop.py", "_next_contact"), ("shot_flight.py", "time_to_depth"),
                                  ("shot_flight.py", "__init__")),
    "impacts (impulse, capture test)": (("shot_capture.py", "capture_impact"), ("impact.py", "impact")),
    "on the rim (the engine)": (("shot_capture.py", "roll_batch"),),
}


def phase_shares(n: int, rho_air: float) -> dict:
    """Shares of the compute time of an n x n map (one thread, under cProfile, which inflates the
    Python-level parts about alike) spent in each of :data:`PHASES` (cumulative time of their functions
    over the whole ``simulate_shots`` call)."""
    import cProfile
    import pstats

    from rimroll.solver import shots

    speed, angle = np.meshgrid(np.linspace(6.5, 7.9, n), np.radians(np.linspace(40.0, 65.0, n)), indexing="ij")
    params = shots.params_for("paper", rho_air=rho_air)
    profile = cProfile.Profile()
    profile.runcall(shots.simulate_shots, {"speed": speed, "angle": angle}, params, shots.Contact())
    stats = pstats.Stats(profile).stats
    total = max(ct for (_, _, name), (_, _, _, ct, _) in stats.items() if name == "simulate_shots")
    shares = {}
    for phase, names in PHASES.items():
        outermost = {}  # a function's cumulative time counted once (impact is also called inside capture_impact)
        def named(path, name, names=names):
            return any(path.endswith(f) and name == n for f, n in names)

        for (path, _, name), (_, _, _, ct, callers) in stats.items():
            if named(path, name) and not any(named(c[0], c[2]) for c in callers):
                outermost[(path, name)] = ct
        shares[phase] = sum(outermost.values()) / total
    shares["other (bookkeeping)"] = 1.0 - sum(shares.values())
    return shares


def warm_engine() -> None:
    """Load (or compile) the rim engine's scene kernels of both maps (vacuum, air): a small warm-up map
    may capture no ball, and a capture in the timed map would otherwise time the compile too."""
    from rimroll.solver import shots, simulate

    for rho_air in (0.0, 1.2):
        simulate(np.array([[1.2, 0.0, 0.0, 10.0]]), shots.params_for("paper", rho_air=rho_air), t_max=0.01, workers=1)


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--workers", type=int, default=2)
    ap.add_argument("--rounds", type=int, default=2)
    ap.add_argument("--n", type=int, default=200, help="grid points per axis (default 200)")
    ap.add_argument("--out", default="bench_results")
    ap.add_argument("--profile-n", type=int, default=60, help="grid points per axis of the profiled map (default 60)")
    ap.add_argument("--no-cold", action="store_true", help="skip the cold compile")
    args = ap.parse_args(argv)
    report = {"n": args.n, "workers": args.workers, "cpus": os.cpu_count(), "load": os.getloadavg()}
    if not args.no_cold:
        report["cold_import_s"], report["cold_first_shot_s"], report["cold_first_air_shot_s"] = cold_compile()
    one_map(8, args.workers, 0.0)  # warm this process's kernels and the study layer
    one_map(8, args.workers, 1.2)
    warm_engine()
    out = pathlib.Path(args.out)
    for label, rho_air in (("vacuum", 0.0), ("drag", 1.2)):
        best, stats = np.inf, None
        for _ in range(args.rounds):
            wall, stats = one_map(args.n, args.workers, rho_air, keep=out / label)
            best = min(best, wall)
        report[label] = {"wall_s": best, **stats, "shots_per_s": stats["shots"] / best,
                         "compute_shares": phase_shares(args.profile_n, rho_air)}
    (out / "shots.json").write_text(json.dumps(report, indent=1))
    print(f"{args.n} x {args.n} shot map, {args.workers} workers ({report['cpus']} cpus, load {report['load'][0]:.2f})")
    if "cold_first_shot_s" in report:
        print(f"cold: import {report['cold_import_s']:.1f} s, first shot {report['cold_first_shot_s']:.1f} s, first "
              f"shot in air (the flight kernel's compile) {report['cold_first_air_shot_s']:.1f} s")
    print("case     wall [s]  shots/s  flight  on rim  impacts/shot  outcomes")
    for label in ("vacuum", "drag"):
        r = report[label]
        shares = ", ".join(f"{k} {v:.1%}" for k, v in sorted(r["outcomes"].items(), key=lambda kv: -kv[1]))
        print(f"{label:8s} {r['wall_s']:8.2f} {r['shots_per_s']:8.0f} {r['share_flight']:7.1%} {r['share_on_rim']:7.1%}"
              f" {r['impacts_per_shot']:12.2f}  {shares}")
        print(f"{'':8s} compute time: " + ", ".join(f"{k} {v:.0%}" for k, v in r["compute_shares"].items()))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
