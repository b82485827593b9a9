"""How the outcomes depend on the launch speed delta of a slip (Sect. 5.2.2): a convergence study.

    python benchmarks/delta_convergence.py [--rtol 1e-10] [--n-beta 30 --n-omega1 45]

The paper launches a slip with "a small positive number" delta; the model's answer is its limit
delta -> 0. This script runs, for delta = 1e-4 .. 1e-8 m/s (u_stop = delta, u_floor = delta / 100,
as the study setting ``delta`` does), at one tight tolerance (default rtol 1e-10, atol 1e-12, DP5):

* the hard set of ``tests/solver/engine/test_stiff_slips.py``: a 1-slip, a 7-slip state, two cycling cells of
  Fig. 12 (their 60th switch, 30 slips), the large-mu state [0.3288, 12, 35, 10] at mu = 1e3, 1e7;
* every state of a (beta, omega1) grid of the Fig. 12 section (mu = 1) that slips at the default
  delta;

and prints, for each delta against the smallest (1e-8 m/s): the fraction of the grid's slipping
states whose outcome differs, the median and largest |t_end - t_end(1e-8)| over the states that fall
in both (s), the slip steps per slip (the cost), and the hard set's t_end values.
"""

from __future__ import annotations

import argparse

import numpy as np

from rimroll.solver import Params, simulate

DELTAS = (1e-4, 1e-5, 1e-6, 1e-7, 1e-8)
HARD = {
    "1 slip": ([0.8, -10.909090909090908, 65.0, 10.0], 1.0, None),
    "7 slips": ([1.1448275862068966, -0.9090909090909083, 65.0, 10.0], 1.0, None),
    "cycling A, 60th switch": ([1.2100418410041842, -2.5069637883008355, 65.0, 10.0], 1.0, 60),
    "cycling B, 60th switch": ([1.18912, 1.83844, 65.0, 10.0], 1.0, 60),
    "large mu 1e3": ([0.3288, 12.0, 35.0, 10.0], 1e3, None),
    "large mu 1e7": ([0.3288, 12.0, 35.0, 10.0], 1e7, None),
}


def switching(delta: float) -> dict:
    return {"delta": delta, "u_stop": delta, "u_floor": delta / 100.0}


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--rtol", type=float, default=1e-10)
    ap.add_argument("--n-beta", type=int, default=30)
    ap.add_argument("--n-omega1", type=int, default=45)
    args = ap.parse_args()
    run = dict(t_max=20.0, rtol=args.rtol, atol=args.rtol * 1e-2)
    beta, omega1 = np.meshgrid(np.linspace(0.8, 1.8, args.n_beta), np.linspace(-20, 20, args.n_omega1), indexing="ij")
    grid = np.stack([beta, omega1, np.full_like(beta, 65.0), np.full_like(beta, 10.0)], axis=-1).reshape(-1, 4)
    slips = simulate(grid, Params(mu=1.0), **run)["slip_phases"] > 0
    x = grid[slips]
    results = {d: simulate(x, Params(mu=1.0), switching=switching(d), **run) for d in DELTAS}
    ref = results[DELTAS[-1]]
    print(f"Fig. 12 section, mu = 1, {args.n_beta} x {args.n_omega1} grid: {len(x)} states that slip; "
          f"rtol {args.rtol:g}; against delta = {DELTAS[-1]:g} m/s")
    print("| delta [m/s] | outcome differs | median / max abs t_end change [s] (falls in both) | slip steps / slip |")
    print("|---|---|---|---|")
    for d, r in results.items():
        differ = r["outcome"] != ref["outcome"]
        both = (r["outcome"] <= 1) & ~differ & (ref["t_end"] > 0)
        change = np.abs(r["t_end"] - ref["t_end"])[both]
        cost = r["n_slip_steps"].sum() / max(1, r["slip_phases"].sum())
        print(f"| {d:g} | {differ.mean():.2%} ({differ.sum()}) | {np.median(change):.1e} / {change.max():.1e} | "
              f"{cost:.0f} |")
    print("\nhard set, t_end [s] (outcome, slips) per delta:")
    for name, (state, mu, switches) in HARD.items():
        cells = []
        for d in DELTAS:
            kw = dict(run, max_switches=switches) if switches else run
            r = simulate(state, Params(mu=mu), switching=switching(d), **kw)
            cells.append(f"{float(r['t_end']):.9f} ({int(r['outcome'])}, {int(r['slip_phases'])})")
        print(f"  {name}: " + " | ".join(cells))


if __name__ == "__main__":
    main()
