"""Cold compile and warm start of the engine (not a test: it times things).

    python benchmarks/cold_compile.py [--repeats 2]

Each measurement runs in a fresh process with an empty kernel cache (``RIMROLL_CACHE_DIR`` set to a
new temporary folder), so it is what a new user meets:

* ``import``: CPU seconds of ``from rimroll import solver``;
* the first ``simulate`` of each of the four named scenes of fig11-13 (rolling only; slipping;
  slipping with drilling k_d; with rolling resistance k_r), in that order in one process, CPU
  seconds each: the first two compile the two kernels (``scene_rolling``, ``scene_hybrid``), the
  last two reuse the hybrid one (their terms are run-time settings);
* then, in a second fresh process with the cache the first one filled, the wall seconds of
  ``study run fig11 --quick`` (warm: every kernel loads from the cache).

CPU time (``time.process_time``) is what the compile costs whatever else the machine runs; the
warm run's wall time depends on the load, printed alongside.
"""

from __future__ import annotations

import argparse
import os
import subprocess
import sys
import tempfile
import time

COLD = """
import time
t0 = time.process_time()
from rimroll import solver
t1 = time.process_time()
out = []
for mu, k_d, k_r in ((float('inf'), 0.0, 0.0), (1.0, 0.0, 0.0), (1.0, 0.02, 0.0), (1.0, 0.0, 0.02)):
    a = time.process_time()
    solver.simulate([[1.1, 2.0, 35.0, 10.0]], solver.Params(mu=mu, k_d=k_d, k_r=k_r), t_max=0.1, workers=1)
    out.append(time.process_time() - a)
print(t1 - t0, *out)
"""


def cold(cache: str) -> list[float]:
    # the compile in this process (not in the child process of solver.engine.compiling), so that its CPU time counts
    env = dict(os.environ, RIMROLL_CACHE_DIR=cache, RIMROLL_COMPILE_HERE="1")
    r = subprocess.run([sys.executable, "-c", COLD], env=env, capture_output=True, text=True, check=True)
    return [float(v) for v in r.stdout.split()]


def warm_quick(cache: str, out: str) -> float:
    env = dict(os.environ, RIMROLL_CACHE_DIR=cache)
    start = time.perf_counter()
    subprocess.run([sys.executable, "-m", "rimroll.study", "run", "fig11", "--quick", "--out", out, "--no-progress"],
                   env=env, capture_output=True, check=True)
    return time.perf_counter() - start


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--repeats", type=int, default=2, help="fresh caches (the best of each figure is kept)")
    args = ap.parse_args()
    colds, warms = [], []
    for _ in range(args.repeats):
        with tempfile.TemporaryDirectory() as cache, tempfile.TemporaryDirectory() as out:
            colds.append(cold(cache))
            warm_quick(cache, out)  # the study's own first run may still compile what simulate did not
            warms.append(warm_quick(cache, out + "/again"))
    best = [min(c[i] for c in colds) for i in range(5)]
    print(f"import {best[0]:.2f} s CPU")
    for name, seconds in zip(("rolling only", "slipping", "slipping + k_d", "slipping + k_r"), best[1:]):
        print(f"first simulate, {name}: {seconds:.2f} s CPU")
    print(f"four scenes: {sum(best[1:]):.2f} s CPU; warm `study run fig11 --quick`: {min(warms):.2f} s wall "
          f"(load {os.getloadavg()[0]:.1f})")


if __name__ == "__main__":
    main()
