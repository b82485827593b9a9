"""Before/after timing of an engine change: a part of the Fig. 11 section, and a slipping one, in two trees at once.

    python benchmarks/engine_change.py BEFORE_TREE [--rounds 7] [--n-beta 60] [--n-omega1 40]

BEFORE_TREE is a package tree of rimroll to compare with (``rimroll/`` inside it, as the ``build/__editable__*``
folder of an editable install holds it); the tree this script is run from is "after". Two worker processes,
one per tree (PYTHONPATH puts BEFORE_TREE first for "before"), each with its own kernel cache folder (its
sources' digest names it), compile the kernels once (first call, timed apart: "compile_s"), then run the cases
in rounds that alternate (odd rounds after first, even rounds before first), one thread each; the best round of
each case counts. Cases: the Fig. 11 section's states (beta in [0.8, 1.8] rad, omega1 in [-20, 20] 1/s, omega2 =
35, omega3 = 10 1/s; --n-beta x --n-omega1 of them) at mu = inf with dp5 and dop853 (rtol 1e-9, atol rtol/100,
t_max 20 s), and the same states at mu = 0.4 (slips: Rosenbrock steps) with dp5. Prints one JSON object
(load average included) and, per case, the after/before ratio of the best times.
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import time

CASES = {"rolling_dp5": (float("inf"), "dp5"), "rolling_dop853": (float("inf"), "dop853"),
         "slipping_dp5": (0.4, "dp5")}
WORKER = r"""
import sys, time, json
import numpy as np
from rimroll import solver
n_beta, n_omega1 = int(sys.argv[1]), int(sys.argv[2])
cases = json.loads(sys.argv[3])
beta, omega1 = np.meshgrid(np.linspace(0.8, 1.8, n_beta), np.linspace(-20.0, 20.0, n_omega1), indexing="ij")
x = np.stack([beta, omega1, np.full_like(beta, 35.0), np.full_like(beta, 10.0)], axis=-1).reshape(-1, 4)
def run(name):
    mu, method = cases[name]
    t0 = time.perf_counter()
    res = solver.simulate(x, solver.Params(mu=mu), t_max=20.0, rtol=1e-9, atol=1e-11, method=method, workers=1)
    return time.perf_counter() - t0, int(np.sum(res["n_steps"]))
compile_s = {name: run(name)[0] for name in cases}
print(json.dumps({"compile_s": compile_s, "file": solver.__file__}), flush=True)
for line in sys.stdin:
    elapsed, steps = run(line.strip())
    print(json.dumps([elapsed, steps]), flush=True)
"""


def start(tree):
    """A worker process over ``tree`` (None: the installed rimroll of this interpreter)."""
    env = dict(os.environ)
    if tree:
        env["PYTHONPATH"] = tree + os.pathsep + env.get("PYTHONPATH", "")
    return subprocess.Popen([sys.executable, "-c", WORKER, str(ARGS.n_beta), str(ARGS.n_omega1), json.dumps(CASES)],
                            stdin=subprocess.PIPE, stdout=subprocess.PIPE, text=True, env=env)


def ask(proc, name):
    proc.stdin.write(name + "\n")
    proc.stdin.flush()
    return json.loads(proc.stdout.readline())


def main():
    workers = {"before": start(ARGS.before), "after": start(None)}
    report = {"load_before": os.getloadavg(), "states": ARGS.n_beta * ARGS.n_omega1}
    for label, proc in workers.items():
        report[label] = json.loads(proc.stdout.readline())
    best = {label: {name: float("inf") for name in CASES} for label in workers}
    steps = {label: {} for label in workers}
    for k in range(ARGS.rounds):
        order = ("after", "before") if k % 2 else ("before", "after")
        for name in CASES:
            for label in order:
                elapsed, n = ask(workers[label], name)
                best[label][name] = min(best[label][name], elapsed)
                steps[label][name] = n
    for proc in workers.values():
        proc.stdin.close()
        proc.wait(timeout=60)
    report.update(best=best, steps=steps, load_after=os.getloadavg(),
                  ratio_after_over_before={name: best["after"][name] / best["before"][name] for name in CASES})
    print(json.dumps(report, indent=1))


if __name__ == "__main__":
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("before", help="package tree of the rimroll to compare with (holds rimroll/)")
    parser.add_argument("--rounds", type=int, default=7)
    parser.add_argument("--n-beta", type=int, default=60)
    parser.add_argument("--n-omega1", type=int, default=40)
    ARGS = parser.parse_args()
    t0 = time.perf_counter()
    main()
    print(f"wall {time.perf_counter() - t0:.0f} s", file=sys.stderr)
