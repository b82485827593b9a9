"""Sect. 5.3 of the paper under both readings of the dissipation (83) (README, "Where rimroll reads the paper").

The paper's conclusions (Sect. 5.3.2), about the states of the former periodic regions of
Figs. 11-13 once dissipation is added (mu = 1, one resistance at a time, 0.02 1/s):

- Fig. 13 (omega2 = 105 1/s): they fall out with either drilling or rolling resistance;
- Figs. 11 and 12 (omega2 = 35, 65 1/s): with drilling resistance all fall out, with rolling
  resistance they fall in.

The former periodic regions are the periodic-rolling cells of the conservative scenes of the
same grid: the rolling-only island (mu = inf) and the slipping island (mu = 1). Each is run in
the drilling and the rolling-resistance scenes under rimroll's reading of (83) (k_r, k_d are the
rates of the rolling equations) and under the alternative one (``solver.physics.params.moment_normalised``:
the moment (82) with C = k j m R^2, giving (1+j) in the rolling components and r for R), and
the outcomes are counted.

    python tests/helpers/dissipation_readings.py [--n-beta 240 --n-omega1 360]

prints the table of the README (the default 240 x 360 grids of Figs. 11-13 take about 2.5
min on 2 cores); ``tests/docs/test_paper_readings.py`` checks it.
"""

from __future__ import annotations

import argparse

import numpy as np

from rimroll import solver
from rimroll.solver.engine import outcomes
from rimroll.solver.physics.params import moment_normalised

FIGURES = {"Fig. 11": 35.0, "Fig. 12": 65.0, "Fig. 13": 105.0}  # omega2 [1/s]; omega3 = 10 1/s
RATE = 0.02  # [1/s], paper Sect. 5.3.2
RUN = dict(rtol=1e-8, atol=1e-10)  # the outcome studies' defaults (docs/outcome-studies.md)
T_MAX, T_MAX_DISSIPATIVE = 20.0, 60.0
READINGS = ("rates", "moment")
ISLANDS = ("rolling_only", "slipping")
DISSIPATIONS = ("drilling", "rolling_resistance")


def section(omega2: float, n_beta: int, n_omega1: int) -> np.ndarray:
    """The (beta, omega1) grid of an outcome section: beta in [0.8, 1.8], omega1 in [-20, 20]: (n_beta, n_omega1, 4)."""
    b, w = np.meshgrid(np.linspace(0.8, 1.8, n_beta), np.linspace(-20.0, 20.0, n_omega1), indexing="ij")
    return np.stack([b, w, np.full_like(b, omega2), np.full_like(b, 10.0)], axis=-1)


def dissipative_params(kind: str, reading: str) -> solver.Params:
    """The scene's Params (mu = 1, one resistance RATE) under a reading of (83)."""
    p = solver.Params(mu=1.0, k_d=RATE) if kind == "drilling" else solver.Params(mu=1.0, k_r=RATE)
    return p if reading == "rates" else moment_normalised(p)


def counts(omega2: float, n_beta: int = 240, n_omega1: int = 360) -> dict:
    """{(island, dissipation, reading): (n_in, n_out, n_on_rim)} for one section."""
    x = section(omega2, n_beta, n_omega1)
    island = {"rolling_only": solver.Params(mu=float("inf")), "slipping": solver.Params(mu=1.0)}
    periodic = {name: solver.simulate(x, p, t_max=T_MAX, **RUN)["outcome"] == outcomes.PERIODIC_ROLLING
                for name, p in island.items()}
    former = periodic["rolling_only"] | periodic["slipping"]
    out = {}
    for kind in DISSIPATIONS:
        for reading in READINGS:
            end = solver.simulate(x[former], dissipative_params(kind, reading), t_max=T_MAX_DISSIPATIVE,
                                  **RUN)["outcome"]
            for name in ISLANDS:
                o = end[periodic[name][former]]
                out[name, kind, reading] = (int((o == outcomes.FALL_IN).sum()), int((o == outcomes.FALL_OUT).sum()),
                                            int((o == outcomes.ON_RIM_AT_T_MAX).sum()))
    return out


def all_counts(n_beta: int = 240, n_omega1: int = 360) -> dict:
    """{figure: counts(...)} for Figs. 11-13."""
    return {fig: counts(omega2, n_beta, n_omega1) for fig, omega2 in FIGURES.items()}


def table(counted: dict) -> list[str]:
    """The README's table rows from ``all_counts``: figure, island, then in / out / on rim per
    dissipation and reading."""
    rows = ["| section | former island | drilling, rates | drilling, moment | rolling res., rates | "
            "rolling res., moment |", "|---|---|---|---|---|---|"]
    for fig, c in counted.items():
        for name in ISLANDS:
            cells = [" / ".join(str(v) for v in c[name, kind, reading])
                     for kind in DISSIPATIONS for reading in READINGS]
            rows.append(f"| {fig} | {name.replace('_', '-')} | " + " | ".join(cells) + " |")
    return rows


if __name__ == "__main__":
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--n-beta", type=int, default=240)
    parser.add_argument("--n-omega1", type=int, default=360)
    args = parser.parse_args()
    for p in (dissipative_params(k, r) for k in DISSIPATIONS for r in READINGS):
        print(f"k_r = {p.k_r:.6f} 1/s, k_d = {p.k_d:.6f} 1/s")
    print("\n".join(table(all_counts(args.n_beta, args.n_omega1))))
