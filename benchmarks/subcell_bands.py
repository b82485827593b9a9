"""Boundary bands thinner than a grid cell: the lower edges of the rolling-only islands of Figs. 12 and 13.

Along one column of the default outcome grid (omega1 = 0.056 1/s, the column next to omega1 = 0;
rolling only; omega3 = 10 1/s), the half period and F2_min of each initial state are computed at
fine resolution (``solver.simulate``, DOP853 at rtol 1e-10) across the last grid cells of the
island, together with what the grid sees at its own points (240 values of beta in [0.8, 1.8]):

* Fig. 12 (omega2 = 65 1/s): a separatrix (the half period peaks without bound) and, 0.5 of a
  grid step below it, the deadlock boundary where F2_min falls to 0 and periodic rolling ends,
  both between the last periodic grid point and the first falling one;
* Fig. 13 (omega2 = 105 1/s): the same structure, but the separatrix lies between two periodic
  grid points; the boundary pair itself holds only the deadlock.

``solver.analysis.boundaries.refine_pairs`` types each boundary pair as the outcome studies do; its type
is printed in each panel next to the grid-only ``classify`` label.

    python benchmarks/subcell_bands.py [--out docs/img]

writes ``subcell_bands.png`` and prints the numbers. Takes about ten seconds.
"""

from __future__ import annotations

import argparse
import pathlib

import numpy as np
from matplotlib.figure import Figure

from rimroll import solver
from rimroll.solver.analysis import boundaries
from rimroll.solver.engine import outcomes
from rimroll.study import plotting as P
from rimroll.study.io import write_figure

PARAMS = solver.Params(mu=float("inf"))
GRID = np.linspace(0.8, 1.8, 240)  # the default beta axis of fig11-13 [rad]
OMEGA1 = float(np.linspace(-20.0, 20.0, 360)[180])  # the grid column next to omega1 = 0 [1/s]
OMEGA3 = 10.0
FINE = dict(t_max=20.0, rtol=1e-10, atol=1e-12, method="dop853")
GRID_RUN = dict(t_max=20.0, rtol=1e-8, atol=1e-10, method="dp5")  # the study's settings
CASES = [("Fig. 12", 65.0, 80), ("Fig. 13", 105.0, 103)]  # (figure, omega2 [1/s], row of the last periodic point)


def states(beta, omega2):
    beta = np.asarray(beta, dtype=float)
    return np.stack([beta, np.full_like(beta, OMEGA1), np.full_like(beta, omega2), np.full_like(beta, OMEGA3)], -1)


def case(name, omega2, row):
    """Fine samples across the cells around grid row ``row`` and the types of its boundary pair."""
    rows = np.arange(row - 3, row + 4)  # the grid-only test reads two periodic rows inside the pair
    grid = solver.simulate(states(GRID[rows], omega2), PARAMS, **GRID_RUN)
    def column(key):  # a 3-column strip: the grid's 2-D form
        return np.repeat(grid[key][:, None], 3, axis=1)
    grid_label = boundaries.classify(column("outcome"), column("f2_min"), column("half_period"), column("t_end"),
                                     PARAMS.m * PARAMS.g)[3, 1]
    pair = boundaries.refine_pairs(states([GRID[row]], omega2), states([GRID[row - 1]], omega2), PARAMS,
                                   **GRID_RUN)
    b_bound = float(pair["periodic"][0, 0])
    b_peak = GRID[row] + float(pair["s_peak"][0]) * (GRID[row - 1] - GRID[row])
    # uniform over the cells shown, plus log-spaced distances around the peak and the boundary
    shown = rows[1:-1]
    d = np.geomspace(1e-9, 1e-3, 60)
    beta = np.unique(np.concatenate([np.linspace(GRID[shown[0]], GRID[shown[-1]], 1200),
                                     b_peak - d, b_peak + d, b_bound - d, b_bound + d]))
    beta = beta[(beta >= GRID[shown[0]]) & (beta <= GRID[shown[-1]])]
    fine = solver.simulate(states(beta, omega2), PARAMS, **FINE)
    return {"name": name, "omega2": omega2, "rows": shown, "outcomes": grid["outcome"][1:-1],
            "half_periods": grid["half_period"][1:-1], "beta": beta, "fine": fine, "pair": pair, "b_bound": b_bound,
            "b_peak": b_peak, "labels": {"grid": int(grid_label), "refined": int(pair["type"][0])}}


def flag(code):
    return boundaries.BOUNDARY_MEANINGS[code].split(":")[0]


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--out", default="docs/img")
    args = ap.parse_args(argv)
    results = [case(*c) for c in CASES]
    weight = PARAMS.m * PARAMS.g
    fig = Figure(figsize=(11.0, 7.0), layout="constrained")
    axes = fig.subplots(2, len(results), sharex="col")
    for col, r in enumerate(results):
        ax_hp, ax_f2 = axes[0, col], axes[1, col]
        per = r["fine"]["outcome"] == outcomes.PERIODIC_ROLLING
        ax_hp.plot(r["beta"][per], r["fine"]["half_period"][per], ".", ms=1.5, color="#31a354")
        ax_f2.plot(r["beta"], r["fine"]["f2_min"] / weight, ".", ms=1.5, color="k")
        step = GRID[1] - GRID[0]
        for ax in (ax_hp, ax_f2):
            for code, b in zip(r["outcomes"], GRID[r["rows"]]):
                ax.axvline(b, color=P.OUTCOME_PALETTE.colour(int(code)), lw=2.0, alpha=0.8, zorder=0)
            ax.axvspan(GRID[r["rows"][1]], GRID[r["rows"][2]], color="0.9", zorder=-1)
            ax.axvline(r["b_bound"], color="k", ls="--", lw=0.9)
            ax.grid(True, alpha=0.3)
        pair_p = r["pair"]
        if pair_p["separatrix"][0] and not pair_p["separatrix_at_boundary"][0]:
            for ax in (ax_hp, ax_f2):
                ax.axvline(r["b_peak"], color="#b8a000", ls=":", lw=1.2)
        top = np.nanmax(r["fine"]["half_period"][per])
        beta_top = r["beta"][per][np.nanargmax(r["fine"]["half_period"][per])]  # where the largest lies
        ax_hp.set_ylim(0.0, 1.08 * top)
        ax_hp.annotate(f"largest half period found: {top:.2f} s\nat beta = {beta_top:.5f} rad",
                       xy=(0.02, 0.97), xycoords="axes fraction", va="top", fontsize=8)
        ax_f2.annotate(f"deadlock boundary (F2_min -> 0) at beta = {r['b_bound']:.5f} rad\n"
                       f"grid pair (beta = {GRID[r['rows'][2]]:.5f} -> {GRID[r['rows'][1]]:.5f}):\n"
                       f"  grid-only classify: {flag(r['labels']['grid'])}\n  refined: {flag(r['labels']['refined'])}",
                       xy=(0.98, 0.45), xycoords="axes fraction", ha="right", va="top", fontsize=8,
                       bbox=dict(fc="white", ec="0.7", alpha=0.9))
        ax_hp.set_title(rf"{r['name']} rolling only: $\omega_1$ = {OMEGA1:.3f} 1/s, $\omega_2$ = {r['omega2']:g} 1/s",
                        fontsize=10)
        ax_hp.set_ylabel("half period [s] (periodic states)")
        ax_f2.set_ylabel(r"$F_{2,min}$ / (m g)")
        ax_f2.set_xlabel(rf"initial height angle $\beta$ [rad] (grid step {step:.5f} rad)")
        ax_f2.set_ylim(-0.05, 1.5)
        print(f"{r['name']} omega1 = {OMEGA1:.4f}: deadlock boundary at beta = {r['b_bound']:.6f}; "
              f"largest half period {top:.3f} s at beta = {beta_top:.6f}; "
              f"grid points {np.round(GRID[r['rows']], 5).tolist()} outcomes {r['outcomes'].tolist()} "
              f"half periods {np.round(r['half_periods'], 3).tolist()}; pair {GRID[r['rows'][2]]:.5f} -> "
              f"{GRID[r['rows'][1]]:.5f}: grid-only {flag(r['labels']['grid'])}, "
              f"refined {flag(r['labels']['refined'])} "
              f"({pair_p['n_runs']} runs)")
    from matplotlib.lines import Line2D
    handles = [Line2D([], [], color=P.OUTCOME_PALETTE.colour(c), lw=2.0,
                      label=f"grid point: {P.OUTCOME_PALETTE.label(c)}")
               for c in (outcomes.FALL_IN, outcomes.PERIODIC_ROLLING)]
    handles += [Line2D([], [], color="0.9", lw=8, label="the boundary pair's band (between its two grid points)"),
                Line2D([], [], color="k", ls="--", lw=0.9, label="where periodic rolling ends (bisection)"),
                Line2D([], [], color="#b8a000", ls=":", lw=1.2, label="separatrix inside the band (half period peak)")]
    fig.legend(handles=handles, loc="outside lower center", ncol=3, fontsize=8, frameon=False)
    fig.suptitle("Boundary bands thinner than a grid cell: the lower edge of the rolling-only islands", fontsize=11)
    print(f"wrote {write_figure(fig, pathlib.Path(args.out) / 'subcell_bands.png', dpi=110)}")


if __name__ == "__main__":
    main()
