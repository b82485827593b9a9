"""The exact boundary curves of the rolling-only sections of Figs. 11-13, and an adaptive map's distance to them.

Study ``exact-boundaries``. Per section (omega2 of fig11-13, ``study.outcome_sections.FIGURES``;
omega3, the (beta, omega1) grid and t_max as in fig11-13; mu = inf, no dissipation: the scene
``rolling_only``): the outcome grid by the reduced solver (``simulate(..., method="reduced")``: an
exact outcome, no step size), every boundary link (two 4-neighbouring cells of different outcome)
bisected until its two ends are adjacent doubles (``solver.analysis.exact_boundaries.bisect_links``),
and the adaptive map of the same grid (``solver.analysis.adaptive_map``, stride ``adaptive_coarse``,
the reduced solver too). Stored per cell (one chunk per section: the links need the whole grid):

- ``crossing_beta`` [rad], ``crossing_beta_kind``: the crossing on the link from the cell to the next
  beta (same omega1), NaN / ``no_link`` where the two cells have the same outcome;
- ``crossing_omega1`` [1/s], ``crossing_omega1_kind``: the same towards the next omega1;
- ``distance_beta`` [rad], ``distance_omega1`` [1/s]: from that crossing along its grid line to the
  nearest crossing of the line by the adaptive map's boundaries (inf: none on the line).

``derive`` adds the polylines through the crossings (``exact_boundaries.exact_curves``) as a
contiguous ragged array, the crossings as a list (beta, omega1, kind, the two outcomes), and per
section the median and max of the distances.
"""

from __future__ import annotations

import numpy as np
from matplotlib.figure import Figure

from rimroll import solver
from rimroll.solver.analysis import adaptive_map, boundary_curves
from rimroll.solver.analysis import exact_boundaries as eb
from rimroll.solver.engine import outcomes, scenes
from rimroll.solver.physics.params import TERM_KEYS
from rimroll.study.outcome_sections import FIGURES, QUICK, SETTINGS, adaptive_axes, section_axes
from rimroll.study.registry import Axis, ReferenceSpec, Study, Var, output_var, register

NAME = "exact-boundaries"
SECTIONS = tuple(omega2 for _, omega2, _ in FIGURES)
"""omega2 [1/s] of the three sections (fig11, fig12, fig13)."""
ROLLING = scenes.NAMED[[s.name for s in scenes.NAMED].index("rolling_only")]

STUDY_SETTINGS = {**{k: SETTINGS[k] for k in ("omega3", "beta_min", "beta_max", "n_beta", "omega1_max", "n_omega1",
                                              "t_max")},
                  "adaptive_coarse": adaptive_map.DEFAULT_COARSE, "f2_rel": eb.F2_REL}
"""The sections' grid and t_max [s] of fig11-13; the adaptive map's stride; ``f2_rel``: f2_min below
f2_rel m g at a rim side's end of a crossing types it ``grazing``."""

KIND_FLAGS = dict(flag_values=(-1, 0, 1, 2), flag_meanings="no_link " + " ".join(eb.KINDS))
OUTCOME_FLAGS = dict(flag_values=tuple(outcomes.OUTCOME_FLAG_VALUES), flag_meanings=outcomes.OUTCOME_FLAG_MEANINGS)
_CROSS = ("located by bisection with the reduced solver until the link's two ends are adjacent doubles "
          "(solver.analysis.exact_boundaries.bisect_links): the midpoint of the two ends")
# `study verify` tolerance of a crossing: 1e-9 rad in beta, 1e-8 1/s in omega1 (a range 40x beta's). A crossing is
# exact to 1 ulp (~2e-16 rad); a change of the solver by ~1e-14 (relative) in t_end or f2_min moves a grazing or
# separatrix root by ~1e-14 times its slope's inverse, far below; the tolerance stays 7 orders below a cell
# (4.2e-3 rad, 0.11 1/s on the default grid), so a crossing found on another link or a bisection stopped early fails.
CROSS_TOL = {"crossing_beta": (1e-9, 0.0), "crossing_omega1": (1e-8, 0.0)}
_DIST = ("distance along the grid line from the exact crossing to the nearest crossing of the same line by the "
         "boundaries of the adaptive map (its crossings at the midpoints of its differing links); inf: the adaptive "
         "map has no boundary on the line; NaN: no link")
VARIABLES = [
    output_var("outcome"), output_var("f2_min"),
    Var("adaptive_outcome", "1", "outcome of the adaptive map of the section", dtype="int8", **OUTCOME_FLAGS,
        pointwise=False),
    Var("crossing_beta", "rad", "beta of the boundary crossing towards the next beta", comment=_CROSS,
        pointwise=False, tolerance=CROSS_TOL["crossing_beta"]),
    Var("crossing_beta_kind", "1", "kind of the boundary crossing towards the next beta", dtype="int8",
        **KIND_FLAGS, pointwise=False),
    Var("crossing_omega1", "s-1", "omega1 of the boundary crossing towards the next omega1", comment=_CROSS,
        pointwise=False, tolerance=CROSS_TOL["crossing_omega1"]),
    Var("crossing_omega1_kind", "1", "kind of the boundary crossing towards the next omega1", dtype="int8",
        **KIND_FLAGS, pointwise=False),
    Var("distance_beta", "rad", "adaptive map's distance to the crossing towards the next beta", comment=_DIST,
        pointwise=False),
    Var("distance_omega1", "s-1", "adaptive map's distance to the crossing towards the next omega1", comment=_DIST,
        pointwise=False),
]


def _axes(s: dict) -> list[Axis]:
    """omega2 [1/s] of the three sections, beta [rad], omega1 [1/s] (the grid of fig11-13)."""
    _, beta, omega1 = section_axes({**s, "mu_slip": 1.0, "k_dissipation": 0.0, "t_max_dissipative": s["t_max"]})
    omega2 = Axis("omega2", np.array(SECTIONS), "s-1", "omega2 of the section",
                  comment="the sections of the paper's Figs. 11, 12, 13")
    return [omega2, beta, omega1]


def runner(p: solver.Params, s: dict, omega2: float):
    """``run(beta, omega1) -> simulate's columns``: the reduced solver, rolling only, at this omega2 [1/s]."""
    params = p.replace(**ROLLING.parameters(1.0, 0.0))

    def run(b, w):
        b, w = np.asarray(b, float), np.asarray(w, float)
        states = np.stack([b, w, np.full_like(b, omega2), np.full_like(b, s["omega3"])], axis=-1)
        return solver.simulate(states, params, t_max=s["t_max"], method="reduced", workers=1)
    return run, params.m * params.g


def per_cell(crossings: eb.Crossings, values, shape: tuple, axis: int, fill, dtype) -> np.ndarray:
    """A grid of ``shape``: ``values`` of the crossings along ``axis`` at their first cell, ``fill`` elsewhere."""
    out = np.full(shape, fill, dtype=dtype)
    m = crossings.axis == axis
    out[crossings.i[m], crossings.j[m]] = np.asarray(values)[m]
    return out


def section(p: solver.Params, s: dict, omega2: float, rows, cols) -> dict:
    """Every per-cell variable of one section (2-D arrays, beta x omega1)."""
    run, weight = runner(p, s, omega2)
    b, w = np.meshgrid(rows, cols, indexing="ij")
    res = run(b.ravel(), w.ravel())
    codes = np.asarray(res["outcome"]).reshape(b.shape)
    x = eb.bisect_links(run, rows, cols, codes, weight, float(s["f2_rel"]))
    fields, _ = adaptive_map.adaptive_map(lambda i, j: run(rows[i], cols[j]), b.shape, int(s["adaptive_coarse"]),
                                          weight=weight, periodic_code=outcomes.PERIODIC_ROLLING,
                                          falls=(outcomes.FALL_IN, outcomes.FALL_OUT, outcomes.ON_RIM_AT_T_MAX))
    dist = eb.line_distances(x, rows, cols, fields["outcome"])
    out = {"outcome": codes.astype(np.int8), "f2_min": np.asarray(res["f2_min"], float).reshape(b.shape),
           "adaptive_outcome": np.asarray(fields["outcome"]).astype(np.int8)}
    for axis, name in ((0, "beta"), (1, "omega1")):
        out[f"crossing_{name}"] = per_cell(x, x.at, b.shape, axis, np.nan, float)
        out[f"crossing_{name}_kind"] = per_cell(x, x.kind, b.shape, axis, -1, np.int8)
        out[f"distance_{name}"] = per_cell(x, dist, b.shape, axis, np.nan, float)
    return out


def _compute(coords, p: solver.Params, s: dict) -> dict:
    omega2, beta, omega1 = coords  # one chunk: one whole section
    out = section(p, s, float(omega2.flat[0]), beta[0, :, 0], omega1[0, 0, :])
    return {k: v[None] for k, v in out.items()}


def crossings_of(ds, k: int) -> eb.Crossings:
    """The located crossings of section k of a results file (``Crossings`` with ``lo = hi`` = the crossing)."""
    parts = []
    for axis, name in ((0, "beta"), (1, "omega1")):
        at = ds[f"crossing_{name}"].transpose("omega2", "beta", "omega1").values[k]
        i, j = np.nonzero(np.isfinite(at))
        kind = ds[f"crossing_{name}_kind"].transpose("omega2", "beta", "omega1").values[k][i, j]
        parts.append((i, j, np.full(i.size, axis, np.int8), at[i, j], kind))
    i, j, ax, at, kind = (np.concatenate(v) for v in zip(*parts))
    codes = ds["outcome"].transpose("omega2", "beta", "omega1").values[k]
    hi_i, hi_j = i + (ax == 0), j + (ax == 1)
    nan = np.full(i.size, np.nan)
    return eb.Crossings(i, j, ax, at, at.copy(), codes[i, j], codes[hi_i, hi_j], nan, nan, kind,
                        np.ones(i.size, bool))


def _curve_vars(parts) -> dict:
    """The polylines of every section as a contiguous ragged array (study.curve_variables' layout)."""
    sizes = np.concatenate([p[0].sizes for p in parts]).astype(np.int32)
    sec = np.concatenate([np.full(p[0].sizes.size, k, np.int8) for k, p in enumerate(parts)])
    return {
        "polyline_node_count": (("polyline",), sizes, {
            "units": "1", "long_name": "number of points of each exact boundary polyline",
            "comment": "a contiguous ragged array: the points of polyline k are polyline_beta and polyline_omega1 "
                       "from the sum of the counts of polylines 0 to k-1 on; the boundary curves of the outcome grid "
                       "(solver.analysis.boundary_curves) with each point on a link moved to its exact crossing "
                       "(solver.analysis.exact_boundaries.exact_curves)"}),
        "polyline_beta": (("polyline_point",), np.concatenate([p[1] for p in parts]),
                          {"units": "rad", "long_name": "beta of the points of the exact boundary polylines"}),
        "polyline_omega1": (("polyline_point",), np.concatenate([p[2] for p in parts]),
                            {"units": "s-1", "long_name": "omega1 of the points of the exact boundary polylines"}),
        "polyline_section": (("polyline",), sec, {
            "units": "1", "long_name": "section (index along omega2) of the polyline"}),
    }


def _crossing_vars(xs, ds) -> dict:
    """The crossings of every section as a list along ``crossing``."""
    rows, cols = ds["beta"].values, ds["omega1"].values
    cat = np.concatenate
    beta = cat([np.where(x.axis == 0, x.at, rows[x.i]) for x in xs])
    omega1 = cat([np.where(x.axis == 0, cols[x.j], x.at) for x in xs])
    flags = {"flag_values": np.array(OUTCOME_FLAGS["flag_values"], dtype="int8"),
             "flag_meanings": OUTCOME_FLAGS["flag_meanings"]}
    return {
        "crossing_list_beta": (("crossing",), beta, {"units": "rad", "long_name": "beta of the exact crossing"}),
        "crossing_list_omega1": (("crossing",), omega1, {"units": "s-1", "long_name": "omega1 of the exact crossing"}),
        "crossing_list_section": (("crossing",), cat([np.full(x.at.size, k, np.int8) for k, x in enumerate(xs)]),
                                  {"units": "1", "long_name": "section (index along omega2) of the crossing"}),
        "crossing_list_kind": (("crossing",), cat([x.kind for x in xs]).astype(np.int8), {
            "units": "1", "long_name": "kind of the exact crossing", "flag_values": np.arange(3, dtype="int8"),
            "flag_meanings": " ".join(eb.KINDS)}),
        "crossing_list_outcome_lo": (("crossing",), cat([x.code_lo for x in xs]).astype(np.int8),
                                     {**flags, "units": "1", "long_name": "outcome on the smaller-coordinate side"}),
        "crossing_list_outcome_hi": (("crossing",), cat([x.code_hi for x in xs]).astype(np.int8),
                                     {**flags, "units": "1", "long_name": "outcome on the larger-coordinate side"}),
    }


def _derive(ds) -> dict:
    """Polylines, crossing list, and the median / max distance of the adaptive map per section."""
    rows, cols = ds["beta"].values, ds["omega1"].values
    xs, parts, stats = [], [], {}
    for k in range(ds.sizes["omega2"]):
        x = crossings_of(ds, k)
        xs.append(x)
        codes = ds["outcome"].transpose("omega2", "beta", "omega1").values[k]
        curves, r, c = eb.exact_curves(x, rows, cols, codes)
        parts.append((curves, r, c))
        for name in ("beta", "omega1"):
            d = ds[f"distance_{name}"].transpose("omega2", "beta", "omega1").values[k]
            d = d[np.isfinite(d)]
            stats.setdefault(name, []).append((np.median(d), d.max()) if d.size else (np.nan, np.nan))
    out = {}
    if any(p[0].sizes.size for p in parts):
        out.update(_curve_vars(parts))
    if any(x.at.size for x in xs):
        out.update(_crossing_vars(xs, ds))
    for name, units in (("beta", "rad"), ("omega1", "s-1")):
        v = np.array(stats[name])
        for n, what in enumerate(("median", "max")):
            out[f"distance_{name}_{what}"] = (("omega2",), v[:, n], {
                "units": units, "long_name": f"{what} over the section of distance_{name} (finite values)"})
    return out


def _plot(ds) -> Figure:
    n = ds.sizes["omega2"]
    fig = Figure(figsize=(5.2 * n, 4.8), layout="constrained")
    rows, cols = ds["beta"].values, ds["omega1"].values
    for k, ax in enumerate(fig.subplots(1, n, squeeze=False)[0]):
        codes = ds["outcome"].transpose("omega2", "beta", "omega1").values[k]
        mesh = ax.pcolormesh(cols, rows, codes, cmap="Pastel1", vmin=0, vmax=8, shading="nearest")
        for code in np.unique(codes):  # legend entries of the outcome colours
            ax.fill_between([], [], color=mesh.cmap(mesh.norm(code)), label=outcomes.OUTCOME_FLAG_MEANINGS.split()[
                list(outcomes.OUTCOME_FLAG_VALUES).index(int(code))].replace("_", " "))
        x = crossings_of(ds, k)
        curves, r, c = eb.exact_curves(x, rows, cols, codes)
        ends = np.cumsum(curves.sizes)
        for m, (size, end) in enumerate(zip(curves.sizes, ends)):
            ax.plot(c[end - size:end], r[end - size:end], "k-", lw=0.6, zorder=3,
                    label="exact boundary" if m == 0 else None)
        adaptive = ds["adaptive_outcome"].transpose("omega2", "beta", "omega1").values[k]
        a = boundary_curves.trace(adaptive)
        ab, aw = boundary_curves.on_axes(a.points, rows, cols)
        ax.plot(aw, ab, "o", ms=1.6, mfc="none", mec="tab:blue", mew=0.5, label="adaptive map's boundary points")
        for kind, colour in zip(range(3), ("r", "m", "g")):
            sel = x.kind == kind
            bb = np.where(x.axis == 0, x.at, rows[x.i])[sel]
            ww = np.where(x.axis == 0, cols[x.j], x.at)[sel]
            ax.plot(ww, bb, ".", color=colour, ms=2.5 if x.at.size < 400 else 1.0, label=f"crossing: {eb.KINDS[kind]}")
        ax.set_title(rf"$\omega_2$ = {float(ds['omega2'][k]):g} 1/s, rolling only (Fig. {11 + k})", fontsize=10)
        ax.set_xlabel(r"$\omega_1$ [1/s]")
        ax.set_ylabel(r"$\beta$ [rad]")
        ax.legend(fontsize=6, loc="upper right")
    fig.suptitle("Exact boundaries (reduced solver, bisection to adjacent doubles) over the outcome map", fontsize=11)
    return fig


def _cost_factor(s: dict) -> float:
    """The cost model's multiplier: the bisection's work grows with the boundary links, about the square root
    of the grid's points, so the cost per point falls as 1 / sqrt(points / the --quick grid's): measured 35 s
    at --quick, about 7 min of one core at the default 240 x 360 (2026-11-28, load 1-2)."""
    quick = QUICK["n_beta"] * QUICK["n_omega1"]
    return min(1.0, float(np.sqrt(quick / (int(s["n_beta"]) * int(s["n_omega1"])))))


DERIVED_DOCS = (
    (("polyline_node_count", "polyline_beta", "polyline_omega1", "polyline_section"), "1, rad, 1/s, 1",
     "the boundary polylines through the exact crossings, a contiguous ragged array"),
    (("crossing_list_beta", "crossing_list_omega1", "crossing_list_kind", "crossing_list_outcome_lo",
      "crossing_list_outcome_hi", "crossing_list_section"), "rad, 1/s, 1",
     "every exact crossing: where, its kind (grazing, separatrix, falls), the outcomes on its two sides"),
    (("distance_beta_median", "distance_beta_max", "distance_omega1_median", "distance_omega1_max"), "rad, 1/s",
     "per section: median and max of the adaptive map's distance to the exact crossings"),
)

register(Study(
    name=NAME,
    title="Exact boundary polylines of the rolling-only sections (paper Figs. 11-13)",
    settings=STUDY_SETTINGS,
    quick=QUICK,
    axes=adaptive_axes(_axes),
    variables=VARIABLES,
    compute=_compute,
    plot=_plot,
    chunks=lambda s: {"omega2": 1, "beta": int(s["n_beta"]), "omega1": int(s["n_omega1"])},
    derive=_derive,
    derived_docs=DERIVED_DOCS,
    ignores={k: "the sections are the conservative rolling-only scene (mu = inf, no dissipation term)"
             for k in ("mu", *TERM_KEYS)},
    # cost: seconds per grid point on one core, warm (--quick on 2 shared cores, load 4, 2026-11-28)
    cost=1.3e-2, cost_factor=_cost_factor, compiles=True,
    reference=ReferenceSpec({"beta": 24, "omega1": 36}, method="reduced solver (exact rolling), bisection of every "
                            "boundary link to adjacent doubles"),
))
