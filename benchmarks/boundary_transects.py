"""Transects across the edges of the periodic-rolling islands of Fig. 12 (omega2 = 65 1/s, omega3 = 10 1/s).

For each transect, a segment from a periodic initial state (inside an island) to a falling one,
the boundary is located by bisection with ``solver.simulate`` (DOP853, rtol 1e-12), then the
half period and F2_min of the periodic states are computed at distances 1e-9 .. 1e-1 of the
segment from the boundary (and t_end, F2_min of the falling states beyond it). A separatrix
boundary shows a half period growing without bound (like log(1/distance)) with F2_min staying
positive; a deadlock boundary shows F2_min falling to 0 with a finite half period.

    python benchmarks/boundary_transects.py [--out docs/img]

writes ``transects_fig12.png`` and prints a table. Takes about a minute on one core.
"""

from __future__ import annotations

import argparse
import pathlib

import numpy as np
from matplotlib.figure import Figure

from rimroll import solver
from rimroll.solver.engine import outcomes
from rimroll.study.io import write_figure

OMEGA2, OMEGA3 = 65.0, 10.0
RUN = dict(t_max=40.0, rtol=1e-12, atol=1e-14, method="dop853")
# (name, scene, inside (beta, omega1), outside (beta, omega1))
TRANSECTS = [
    ("flat lower edge, omega1 = 0", "rolling only", (1.20, 0.0), (1.10, 0.0)),
    ("flat lower edge, omega1 = -2", "rolling only", (1.20, -2.0), (1.10, -2.0)),
    ("flat lower edge, omega1 = +2", "rolling only", (1.20, 2.0), (1.10, 2.0)),
    ("left curved edge, beta = 1.2", "rolling only", (1.20, 0.0), (1.20, -5.0)),
    ("right curved edge, beta = 1.2", "rolling only", (1.20, 0.0), (1.20, 5.0)),
    ("lower edge with slipping, omega1 = 0", "slipping", (1.22, 0.0), (1.12, 0.0)),
    ("left edge with slipping, beta = 1.2", "slipping", (1.20, 0.0), (1.20, -5.0)),
]
SCENES = {"rolling only": solver.Params(mu=float("inf")), "slipping": solver.Params(mu=1.0)}
# fraction of the segment from the boundary; 1e-9 of 0.1 rad is 1e-10 rad: far below any grid
DISTANCES = np.geomspace(1e-9, 1e-1, 17)


def states_at(inside, outside, s):
    """Initial states (beta, omega1, omega2, omega3) at fractions s of the segment."""
    s = np.asarray(s, dtype=float)[..., None]
    a = np.array([inside[0], inside[1], OMEGA2, OMEGA3])
    b = np.array([outside[0], outside[1], OMEGA2, OMEGA3])
    return a + s * (b - a)


def boundary(inside, outside, params, n=45):
    """Fraction s* of the segment where periodic rolling ends (bisection to 2**-n)."""
    lo, hi = 0.0, 1.0
    ends = solver.simulate(states_at(inside, outside, [lo, hi]), params, **RUN)["outcome"]
    if ends[0] != outcomes.PERIODIC_ROLLING or ends[1] == outcomes.PERIODIC_ROLLING:
        raise ValueError(f"segment {inside} -> {outside} does not cross a periodic boundary: outcomes {ends}")
    for _ in range(n):
        mid = 0.5 * (lo + hi)
        if solver.simulate(states_at(inside, outside, [mid]), params, **RUN)["outcome"][0] == outcomes.PERIODIC_ROLLING:
            lo = mid
        else:
            hi = mid
    return lo, hi


def transect(name, scene, inside, outside):
    params = SCENES[scene]
    lo, hi = boundary(inside, outside, params)
    s_in = lo - DISTANCES
    s_out = hi + DISTANCES
    keep_in, keep_out = s_in > 0, s_out < 1
    r_in = solver.simulate(states_at(inside, outside, s_in[keep_in]), params, **RUN)
    r_out = solver.simulate(states_at(inside, outside, s_out[keep_out]), params, **RUN)
    x_star = states_at(inside, outside, [lo])[0]
    length = np.hypot(outside[0] - inside[0], (outside[1] - inside[1]) / 20.0)
    return {"name": name, "scene": scene, "x_star": x_star, "d_in": DISTANCES[keep_in], "d_out": DISTANCES[keep_out],
            "in": r_in, "out": r_out, "weight": params.m * params.g, "length": length}


def verdict(t):
    """The boundary's type from the periodic side (nearest 1e-9 .. 1e-5 of the transect) and the far side.

    deadlock: F2_min -> 0 while the half period converges; separatrix: the half period keeps
    growing (> 0.03 s per decade of distance) while F2_min stays; slipping_induced (finite mu):
    neither, and the far side slips (slip phases) instead of falling at once.
    """
    per = t["in"]["outcome"] == outcomes.PERIODIC_ROLLING
    d, hp, f2 = t["d_in"][per], t["in"]["half_period"][per], t["in"]["f2_min"][per]
    near = d <= 1e-5
    hp_per_decade = (hp[near][0] - hp[near][-1]) / np.log10(d[near][-1] / d[near][0])
    vanishes = f2[0] < 0.02 * t["weight"]
    if vanishes and abs(hp_per_decade) < 1e-3:
        return "deadlock"
    if hp_per_decade > 0.03 and not vanishes:
        return "separatrix"
    if not vanishes and np.median(t["out"]["slip_phases"]) > 0:
        return "slipping-induced"
    return "unclear"


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--out", default="docs/img")
    args = ap.parse_args(argv)
    results = [transect(*t) for t in TRANSECTS]
    fig = Figure(figsize=(12.0, 8.0), layout="constrained")
    ax_hp, ax_f2, ax_tout, ax_f2out = fig.subplots(2, 2).flat
    print(f"{'transect':40s} {'scene':13s} {'boundary (beta, omega1)':>24s} {'hp 1e-1':>8s} {'hp 1e-9':>8s} "
          f"{'F2min 1e-1':>10s} {'F2min 1e-9':>10s} {'out: outcome, t_end, slips':>26s}  type")
    for k, t in enumerate(results):
        style = dict(color=f"C{k}", marker="o", ms=3, lw=1.2, ls="-" if t["scene"] == "rolling only" else "--")
        per = t["in"]["outcome"] == outcomes.PERIODIC_ROLLING
        kind = verdict(t)
        span = (f"{abs(TRANSECTS[k][3][0] - TRANSECTS[k][2][0]):g} rad"
                if TRANSECTS[k][3][0] != TRANSECTS[k][2][0]
                else f"{abs(TRANSECTS[k][3][1] - TRANSECTS[k][2][1]):g} 1/s")
        label = f"{t['name']} ({t['scene']}, transect {span}): {kind}"
        ax_hp.semilogx(t["d_in"][per], t["in"]["half_period"][per], label=label, **style)
        ax_f2.semilogx(t["d_in"][per], t["in"]["f2_min"][per] / t["weight"], **style)
        ax_tout.semilogx(t["d_out"], t["out"]["t_end"], **style)
        ax_f2out.semilogx(t["d_out"], t["out"]["f2_min"] / t["weight"], **style)
        o = t["out"]
        print(f"{t['name']:40s} {t['scene']:13s} ({t['x_star'][0]:.9f}, {t['x_star'][1]:+.6f}) "
              f"{t['in']['half_period'][per][-1]:8.3f} {t['in']['half_period'][per][0]:8.3f} "
              f"{t['in']['f2_min'][per][-1]:10.4f} {t['in']['f2_min'][per][0]:10.4f} "
              f"{solver.OUTCOME_MEANINGS[int(o['outcome'][0])].split(':')[0]:>16s} {o['t_end'][0]:6.3f} "
              f"{int(o['slip_phases'][0]):3d}  {kind}")
    ax_hp.set_ylabel("half period of the periodic state [s]")
    ax_f2.set_ylabel(r"$F_{2,min}$ / (m g) of the periodic state")
    ax_tout.set_ylabel("time on the rim of the non-periodic state [s]\n(40 s = t_max: still on the rim)")
    ax_f2out.set_ylabel(r"$F_{2,min}$ / (m g) of the non-periodic state (0: it left the rim)")
    for ax in (ax_hp, ax_f2, ax_tout, ax_f2out):
        ax.set_xlabel("distance from the boundary (fraction of the transect)")
        ax.grid(True, which="both", alpha=0.3)
    ax_hp.set_title("periodic side", fontsize=10)
    ax_tout.set_title("non-periodic side", fontsize=10)
    ax_f2.set_ylim(bottom=0)
    fig.legend(loc="outside lower center", ncol=2, fontsize=8, frameon=False)
    fig.suptitle(r"Transects across the edges of the periodic islands of Fig. 12 ($\omega_2$ = 65 1/s, "
                 r"$\omega_3$ = 10 1/s), boundary located by bisection; DOP853 rtol 1e-12", fontsize=11)
    print(f"wrote {write_figure(fig, pathlib.Path(args.out) / 'transects_fig12.png', dpi=110)}")


if __name__ == "__main__":
    main()
