"""Exact boundary curves of the Figs. 11-13 rolling-only sections, and how far an adaptive map's lie from them.

    python benchmarks/exact_boundaries.py                     # 240 x 360 (the studies' grid), the three sections
    python benchmarks/exact_boundaries.py --n-beta 24 --n-omega1 36 --omega2 35

Per section (omega2 = 35, 65, 105 1/s; omega3 = 10 1/s; mu = inf; t_max = 20 s): the outcome grid by the
reduced solver (``simulate(..., method="reduced")``), every boundary crossing of a grid line bisected to
adjacent doubles (``solver.analysis.exact_boundaries``), the curves through them, and the adaptive map
of the same grid (``solver.analysis.adaptive_map.adaptive_map``, stride ``--coarse``, the reduced solver too): the
distance along each grid line from each exact crossing to the adaptive map's nearest crossing of that
line (rad on lines of constant omega1, 1/s on lines of constant beta), median and max. Writes
``exact_boundaries.nc`` (polylines as a contiguous ragged array, crossings with their kind) and
``exact_boundaries.png`` into ``--out`` (default bench_results/), and prints one line per section.
"""

from __future__ import annotations

import argparse
import pathlib
import time

import numpy as np
import xarray as xr
from matplotlib.figure import Figure

from rimroll import solver
from rimroll.solver.analysis import adaptive_map as adaptive
from rimroll.solver.analysis import exact_boundaries as eb
from rimroll.solver.engine import outcomes

OMEGA2 = (35.0, 65.0, 105.0)  # [1/s] Figs. 11, 12, 13
FIGURE = {35.0: "fig11", 65.0: "fig12", 105.0: "fig13"}


def runner(params, omega2: float, omega3: float = 10.0, t_max: float = 20.0):
    def run(beta, omega1):
        beta, omega1 = np.asarray(beta, float), np.asarray(omega1, float)
        states = np.stack([beta, omega1, np.full_like(beta, omega2), np.full_like(beta, omega3)], axis=-1)
        return solver.simulate(states, params, t_max=t_max, method="reduced", workers=1)
    return run


def one_section(params, omega2, rows, cols, coarse) -> dict:
    run = runner(params, omega2)
    b, w = np.meshgrid(rows, cols, indexing="ij")
    start = time.perf_counter()
    codes = np.asarray(run(b.ravel(), w.ravel())["outcome"]).reshape(b.shape)
    grid_s = time.perf_counter() - start
    start = time.perf_counter()
    crossings = eb.bisect_links(run, rows, cols, codes, params.m * params.g)
    bisect_s = time.perf_counter() - start
    curves, r, c = eb.exact_curves(crossings, rows, cols, codes)
    fields, level = adaptive.adaptive_map(lambda i, j: run(rows[i], cols[j]), b.shape, coarse,
                                          weight=params.m * params.g, periodic_code=outcomes.PERIODIC_ROLLING,
                                          falls=(outcomes.FALL_IN, outcomes.FALL_OUT, outcomes.ON_RIM_AT_T_MAX))
    dist = eb.line_distances(crossings, rows, cols, fields["outcome"])
    return {"omega2": omega2, "codes": codes, "crossings": crossings, "curves": curves, "r": r, "c": c,
            "dist": dist, "adaptive_differs": int((fields["outcome"] != codes).sum()),
            "adaptive_simulated": int((level != adaptive.FILLED).sum()), "grid_s": grid_s, "bisect_s": bisect_s}


def summary(s, rows, cols) -> str:
    x = s["crossings"]
    kinds = ", ".join(f"{k} {int((x.kind == n).sum())}" for n, k in enumerate(eb.KINDS))
    parts = []
    for axis, unit, step in ((0, "rad", rows[1] - rows[0]), (1, "1/s", cols[1] - cols[0])):
        d = s["dist"][x.axis == axis]
        fin = d[np.isfinite(d)]
        parts.append(f"along {'beta' if axis == 0 else 'omega1'}: {d.size} crossings, adaptive map's median "
                     f"{np.median(fin):.3g} {unit}, max {fin.max():.3g} {unit} (half a cell {step / 2:.3g}), "
                     f"{int((~np.isfinite(d)).sum())} with no adaptive crossing on the line" if fin.size else "none")
    return (f"{FIGURE.get(s['omega2'], s['omega2'])}: {x.at.size} crossings ({kinds}), all to adjacent doubles: "
            f"{bool(x.converged.all())}; " + "; ".join(parts)
            + f"; adaptive map: {s['adaptive_simulated']} cells simulated, {s['adaptive_differs']} outcomes differ; "
            f"grid {s['grid_s']:.1f} s, bisection {s['bisect_s']:.1f} s")


def dataset(sections, rows, cols) -> xr.Dataset:
    pts_r, pts_c, sizes, sec_curve, cross = [], [], [], [], {k: [] for k in ("section", "axis", "at", "fixed",
                                                                               "kind", "distance_adaptive")}
    for k, s in enumerate(sections):
        pts_r.append(s["r"])
        pts_c.append(s["c"])
        sizes.append(s["curves"].sizes)
        sec_curve.append(np.full(len(s["curves"]), k))
        x = s["crossings"]
        cross["section"].append(np.full(x.at.size, k))
        cross["axis"].append(x.axis)
        cross["at"].append(x.at)
        cross["fixed"].append(np.where(x.axis == 0, cols[x.j], rows[x.i]))
        cross["kind"].append(x.kind)
        cross["distance_adaptive"].append(s["dist"])
    cat = np.concatenate
    return xr.Dataset({
        "boundary_beta": ("boundary_point", cat(pts_r), {"units": "rad"}),
        "boundary_omega1": ("boundary_point", cat(pts_c), {"units": "s-1"}),
        "boundary_node_count": ("boundary_curve", cat(sizes), {"long_name": "points of each curve, one after the "
                                                                             "other along boundary_point"}),
        "boundary_curve_section": ("boundary_curve", cat(sec_curve)),
        **{f"crossing_{k}": ("crossing", cat(v)) for k, v in cross.items()},
        "outcome": (("section", "beta", "omega1"), np.stack([s["codes"] for s in sections]).astype(np.int8)),
    }, coords={"omega2": ("section", [s["omega2"] for s in sections]), "beta": rows, "omega1": cols},
        attrs={"crossing_kind_meanings": " ".join(eb.KINDS),
               "comment": "exact boundaries (solver.analysis.exact_boundaries) with the reduced solver; "
                          "crossing_at: the crossing's beta [rad] (axis 0) or omega1 [1/s] (axis 1), crossing_fixed "
                          "the other coordinate; distance_adaptive in the units of crossing_at"})


def figure(sections, rows, cols) -> Figure:
    fig = Figure(figsize=(5.0 * len(sections), 4.5), layout="constrained")
    for ax, s in zip(fig.subplots(1, len(sections), squeeze=False)[0], sections):
        ax.pcolormesh(cols, rows, s["codes"], cmap="Pastel1", vmin=0, vmax=8, shading="nearest")
        for k in range(len(s["curves"])):
            lo = int(s["curves"].sizes[:k].sum())
            n = int(s["curves"].sizes[k])
            ax.plot(s["c"][lo:lo + n], s["r"][lo:lo + n], "k-", lw=0.7)
        x = s["crossings"]
        for n, style in enumerate(("r.", "b.", "g.")):
            m = x.kind == n
            rr = np.where(x.axis == 0, x.at, rows[x.i])[m]
            cc = np.where(x.axis == 0, cols[x.j], x.at)[m]
            ax.plot(cc, rr, style, ms=2, label=eb.KINDS[n])
        ax.set_title(f"omega2 = {s['omega2']:g} 1/s, rolling only: exact boundaries")
        ax.set_xlabel("omega1 [1/s]")
        ax.set_ylabel("beta [rad]")
        ax.legend(fontsize=7, loc="upper right")
    return fig


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", type=pathlib.Path, default=pathlib.Path("bench_results"))
    parser.add_argument("--n-beta", type=int, default=240)
    parser.add_argument("--n-omega1", type=int, default=360)
    parser.add_argument("--omega2", type=float, nargs="+", default=list(OMEGA2))
    parser.add_argument("--coarse", type=int, default=adaptive.DEFAULT_COARSE)
    args = parser.parse_args(argv)
    params = solver.Params(mu=np.inf)
    rows, cols = np.linspace(0.8, 1.8, args.n_beta), np.linspace(-20.0, 20.0, args.n_omega1)
    sections = []
    for omega2 in args.omega2:
        sections.append(one_section(params, omega2, rows, cols, args.coarse))
        print(summary(sections[-1], rows, cols), flush=True)
    args.out.mkdir(parents=True, exist_ok=True)
    dataset(sections, rows, cols).to_netcdf(args.out / "exact_boundaries.nc")
    figure(sections, rows, cols).savefig(args.out / "exact_boundaries.png", dpi=130)
    print(f"wrote {args.out / 'exact_boundaries.nc'} and {args.out / 'exact_boundaries.png'}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
