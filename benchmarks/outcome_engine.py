"""Benchmark of the outcome engine on the Fig. 11 section (86,400 states; not a test).

    python benchmarks/outcome_engine.py [--repeat N]

Times ``solver.simulate(method="dp5")`` (the engine's integrator, not the exact solver that the default
"auto" picks for rolling only) rolling only at rtol 1e-6 and 1e-8 and with slipping (mu = 1) at
1e-8 (atol = rtol / 100), after a warm-up call that loads or compiles the kernels (the compile
is not timed), and reports the best of N runs, the mean attempted steps per state and the
fraction of steps whose dense output the grazing check searched (``n_searched / n_steps``).
Compare engines by running it from two checkouts in alternation on the same machine.
"""

from __future__ import annotations

import argparse
import json
import time

import numpy as np

from rimroll import solver

CASES = (("rolling_only_rtol_1e-6", float("inf"), 1e-6), ("rolling_only_rtol_1e-8", float("inf"), 1e-8),
         ("slipping_mu_1_rtol_1e-8", 1.0, 1e-8))


def section():
    b, w = np.meshgrid(np.linspace(0.8, 1.8, 240), np.linspace(-20, 20, 360), indexing="ij")
    return np.stack([b, w, np.full_like(b, 35.0), np.full_like(b, 10.0)], -1)


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeat", type=int, default=3, help="timed runs per case (best is reported)")
    args = parser.parse_args(argv)
    x = section()
    out = {}
    for name, mu, rtol in CASES:
        p = solver.Params(mu=mu)
        solver.simulate(x[:2, :2], p, rtol=rtol, atol=rtol * 1e-2, method="dp5")  # load or compile, untimed
        times = []
        for _ in range(args.repeat):
            t0 = time.perf_counter()
            r = solver.simulate(x, p, rtol=rtol, atol=rtol * 1e-2, method="dp5")
            times.append(time.perf_counter() - t0)
        out[name] = {"seconds_best": round(min(times), 4), "seconds_all": [round(t, 4) for t in times],
                     "steps_per_state": round(float(r["n_steps"].mean()), 3),
                     "searched_fraction": round(float(r["n_searched"].sum() / r["n_steps"].sum()), 4)}
    print(json.dumps(out, indent=1))


if __name__ == "__main__":
    main()
