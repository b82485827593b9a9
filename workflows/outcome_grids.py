"""Outcome sections of the phase space (paper Figs. 11-13): in, out, periodic, still on the rim.

Each study is the grid of an outcome section (docs/outcome-studies.md: beta x omega1 at fixed
omega2, omega3 = 10 1/s) in four scenes, stored along a ``scene`` dimension of string labels
whose non-index coordinates ``mu``, ``k_r``, ``k_d`` and ``t_max`` say what each scene models
(``ds.sel(scene="slipping")``):

- ``rolling_only``: mu = inf, conservative
- ``slipping``: mu = 1, conservative
- ``drilling``: slipping + drilling resistance (mu = 1, k_d = 0.02 1/s)
- ``rolling_resistance``: slipping + rolling resistance (mu = 1, k_r = 0.02 1/s)

The physical settings (r, R, a, m, j, g) apply to every scene; the scene's mu, k_r, k_d
override the run's. Every result field of ``solver.simulate`` is stored (with ``on_rim_reason``:
why a run is still on the rim), plus two variables derived once from the whole grid:

- ``boundary_type`` (``solver.analysis.boundaries``): which cells lie on a boundary of periodic rolling and
  of which kind (deadlock, separatrix, slipping-induced, or a band thinner than a cell holding a
  separatrix and a deadlock; paper Sect. 5.1, 5.2.3), each boundary pair of a conservative scene
  refined by simulation (``boundaries.refine_grid``);
- ``former_periodic``: the periodic islands of the conservative scenes (rolling only, slipping),
  with the fate of their states in each dissipative scene in its attributes (Sect. 5.3.2).
"""

from __future__ import annotations

import numpy as np
from matplotlib.figure import Figure
from matplotlib.lines import Line2D

from rimroll import solver
from rimroll.solver.analysis import adaptive_map, boundaries
from rimroll.solver.engine import outcomes
from rimroll.study import curve_variables as curves
from rimroll.study import plotting as P
from rimroll.study.dataset import params_of, setting_of
from rimroll.study.outcome_sections import (
    ADAPTIVE_SETTINGS,
    FIGURES,
    LEVEL_ATTRS,
    QUICK,
    SCENE_IGNORES,
    SETTINGS,
    adaptive_axes,
    adaptive_chunks,
    adaptive_cost_factor,
    engine_options,
    map_section,
    scene_params,
    section_axes,
    steady_beta0,
)
from rimroll.study.registry import ReferenceSpec, Study, Var, output_var, register

REFINE_LEVEL = Var("refine_level", "1", LEVEL_ATTRS["long_name"], dtype="int8",
                   comment=LEVEL_ATTRS["comment"], compared=False)
"""Per cell: the level of the adaptive map at which it was simulated, or -1 where filled (a full map: 0)."""
VARIABLES = [output_var(name) for name in (
    "outcome", "t_end", "f2_min", "half_period", "revolutions", "slip_time", "energy_drift", "beta_end", "omega1_end",
    "omega2_end", "omega3_end", "steady_h", "slip_phases", "n_steps", "status", "on_rim_reason")] + [REFINE_LEVEL]
"""The outputs of ``simulate`` stored for every cell (``solver.engine.outputs``), in file order, and
``refine_level`` (``solver.analysis.adaptive_map``)."""


def _compute(coords, p: solver.Params, s: dict) -> dict:
    scene, beta, omega1 = coords
    params, t_max = scene_params(p, s, scene.flat[0])  # chunks hold one scene (chunks={"scene": 1})

    def run(b, w):
        states = np.stack([b, w, np.full_like(b, s["omega2"]), np.full_like(b, s["omega3"])], axis=-1)
        return solver.simulate(states, params, t_max=t_max, rtol=s["rtol"], atol=s["atol"], method=s["method"],
                               workers=1, backend=s["backend"], **engine_options(s))
    return map_section(run, beta, omega1, s, params.m * params.g)


def _chunks(s: dict) -> dict:
    """One scene per chunk, 24 rows of beta (an adaptive map: its whole grid)."""
    return adaptive_chunks(s, {"scene": 1, "beta": 24})


BOUNDARY_ATTRS = {
    "units": "1",
    "long_name": "type of the boundary of periodic rolling at this initial state (paper Sect. 5.1)",
    "flag_values": np.array(boundaries.BOUNDARY_FLAG_VALUES, dtype="int8"),
    "flag_meanings": boundaries.BOUNDARY_FLAG_MEANINGS,
    "comment": "conservative scenes: every pair of a periodic cell and a falling or still-on-the-rim 4-neighbour "
               "is typed by simulation along the segment between them (solver.analysis.boundaries.refine_grid, with "
               + ", ".join(f"{k}={v:g}" for k, v in boundaries.REFINE_DEFAULTS.items())
               + f", f2_rel={boundaries.DEFAULTS['f2_rel']:g}; the scene's t_max, rtol, atol and method; with finite "
               "mu the runs stop at the first slip); a cell takes the first type of its pairs in the order "
               "separatrix_and_deadlock, deadlock, slipping_induced, separatrix, undetermined. A pair that cannot "
               "be refined keeps the grid-only label of solver.analysis.boundaries.classify ("
               + ", ".join(f"{k}={v:g}" for k, v in boundaries.DEFAULTS.items()) + ")",
}

ISLANDS = ("rolling_only", "slipping")
"""The periodic islands of ``former_periodic``: those of the conservative scene with mu = inf and of the
one with finite mu."""
FATES = ("fall_in", "fall_out", "other")
FORMER_MEANINGS = {0: "none", 1: "rolling_only_island", 2: "slipping_island", 3: "both_islands"}


def _recorded(ds) -> dict:
    """The engine settings recorded in a results file (``sections.engine_options`` reads them)."""
    out = {}
    for name in ("delta", "slip_method"):
        try:
            out[name] = setting_of(ds, name)
        except KeyError:  # a file written before the setting existed: the default
            pass
    return out


def _boundary_labels(ds, k, outcome, f2, hp, t_end, weight, rolling) -> np.ndarray:
    """``boundary_type`` of scene k: grid labels, refined by simulation in a conservative scene."""
    p = params_of(ds)
    mu, k_r, k_d = (float(ds[name].values[k]) for name in ("mu", "k_r", "k_d"))
    ref = outcome[rolling[0]] if rolling and np.isfinite(mu) else None
    grid = boundaries.classify(outcome[k], f2[k], hp[k], t_end[k], weight, rolling_outcome=ref)
    if k_r != 0 or k_d != 0 or not (grid != boundaries.NOT_BOUNDARY).any():
        return grid
    beta, omega1 = np.meshgrid(ds["beta"].values, ds["omega1"].values, indexing="ij")
    omega2, omega3 = float(setting_of(ds, "omega2")), float(setting_of(ds, "omega3"))
    states = np.stack([beta, omega1, np.full_like(beta, omega2), np.full_like(beta, omega3)], axis=-1)
    labels, _ = boundaries.refine_grid(outcome[k], states, p.replace(mu=mu, k_r=k_r, k_d=k_d),
                                       float(ds["t_max"].values[k]), fallback=grid,
                                       rtol=float(setting_of(ds, "rtol")), atol=float(setting_of(ds, "atol")),
                                       method=str(setting_of(ds, "method")), **engine_options(_recorded(ds)))
    return labels


def former_periodic(outcome, mu, conservative) -> tuple[np.ndarray, dict]:
    """The periodic islands of the conservative scenes and the fate of their states in the others.

    ``outcome`` (scene, beta, omega1) codes; ``mu``, ``conservative``: per scene. Returns (flags
    (beta, omega1) int8: 1 periodic rolling only (mu = inf), 2 periodic with slipping (finite mu),
    3 both, 0 neither; and ``{(scene index, island): (counts, fractions)}`` of every
    dissipative scene and island, counts [cells] of the island's states that fall in, fall out
    or do anything else (still on the rim, ...) in that scene, fractions [1] of the island).
    """
    outcome = np.asarray(outcome)
    flags = np.zeros(outcome.shape[1:], dtype=np.int8)
    masks = {}
    for bit, (island, want_inf) in enumerate(((ISLANDS[0], True), (ISLANDS[1], False))):
        scenes = [k for k in range(outcome.shape[0]) if conservative[k] and bool(np.isinf(mu[k])) == want_inf]
        if scenes:
            masks[island] = outcome[scenes[0]] == outcomes.PERIODIC_ROLLING
            flags |= (masks[island] * (1 << bit)).astype(np.int8)
    fates = {}
    for k in range(outcome.shape[0]):
        if conservative[k]:
            continue
        for island, mask in masks.items():
            fate = outcome[k][mask]
            counts = np.array([(fate == outcomes.FALL_IN).sum(), (fate == outcomes.FALL_OUT).sum(), 0], dtype=np.int64)
            counts[2] = fate.size - counts[:2].sum()
            fates[(k, island)] = (counts, counts / fate.size if fate.size else np.full(3, np.nan))
    return flags, fates


def _former_attrs(ds, flags, fates) -> dict:
    """Attributes of ``former_periodic``: the fates, with what they count."""
    attrs = {
        "units": "1",
        "long_name": "periodic islands of the conservative scenes at this initial state (where dissipation "
                     "sends the former periodic states, paper Sect. 5.3.2)",
        "flag_values": np.array(tuple(FORMER_MEANINGS), dtype="int8"),
        "flag_meanings": " ".join(FORMER_MEANINGS.values()),
        "fate_order": " ".join(FATES),
        "comment": "rolling_only_island: periodic_rolling in the scene with mu = inf, slipping_island: in the "
                   "conservative scene with finite mu (the same in every scene of this file). For each "
                   "dissipative scene S and island I: fate_counts_S_I [cells] = how many of the island's states "
                   "fall_in, fall_out and do anything else (other: still on the rim, ...) in S, in the order of "
                   "fate_order; fate_fractions_S_I [1] = those counts over island_cells_I, the island's size [cells]",
    }
    for bit, island in enumerate(ISLANDS):
        attrs[f"island_cells_{island}"] = np.int64(((flags >> bit) & 1).sum())
    scenes = [str(v) for v in ds["scene"].values]
    for (k, island), (counts, fractions) in fates.items():
        attrs[f"fate_counts_{scenes[k]}_{island}"] = counts
        attrs[f"fate_fractions_{scenes[k]}_{island}"] = fractions
    return attrs


def _derive(ds) -> dict:
    """``boundary_type`` of every scene, from the whole (beta, omega1) grid of each (conservative scenes
    refined by simulation), and ``former_periodic`` with the fates of the islands."""
    p = params_of(ds)
    dims = ("scene", "beta", "omega1")
    def get(name):
        return ds[name].transpose(*dims).values
    outcome, f2, hp, t_end = get("outcome"), get("f2_min"), get("half_period"), get("t_end")
    mu = ds["mu"].values
    conservative = (ds["k_r"].values == 0) & (ds["k_d"].values == 0)
    rolling = [k for k in range(mu.size) if np.isinf(mu[k]) and conservative[k]]
    labels = np.empty(outcome.shape, dtype=np.int8)
    for k in range(mu.size):
        labels[k] = _boundary_labels(ds, k, outcome, f2, hp, t_end, p.m * p.g, rolling)
    flags, fates = former_periodic(outcome, mu, conservative)
    former = np.broadcast_to(flags, outcome.shape).copy()
    out = {"boundary_type": (dims, labels, BOUNDARY_ATTRS),
           "former_periodic": (dims, former, _former_attrs(ds, flags, fates))}
    out.update(curves.variables(outcome, labels, ds["beta"].values, ds["omega1"].values,
                                [str(v) for v in ds["scene"].values]))
    if "refine_level" in ds:  # files written before adaptive maps have none
        out["n_simulated"] = (("scene",), adaptive_map.n_simulated(get("refine_level")).astype(np.int32),
                              N_SIMULATED_ATTRS)
    return out


N_SIMULATED_ATTRS = {"units": "1", "long_name": "trajectories simulated for the map of the scene (initial states)",
                     "comment": "a full map: every cell; an adaptive map (setting adaptive = 1): the cells with "
                                "refine_level >= 0 (the boundary typing of boundary_type simulates more, along the "
                                "boundary pairs, in either map)"}


BOUNDARY_STYLES = {  # how the plot draws each boundary curve by its type (study.curve_variables)
    boundaries.NOT_BOUNDARY: dict(color="0.2", lw=0.5, label="boundary between other outcomes"),
    boundaries.DEADLOCK: dict(color="k", lw=1.1, label=r"deadlock boundary ($F_{2,min} \to 0$)"),
    boundaries.SEPARATRIX: dict(color="#ffff33", lw=1.3, label=r"separatrix boundary (half period $\to \infty$)"),
    boundaries.SLIPPING_INDUCED: dict(color="#e7298a", lw=1.3, label="slipping-induced boundary"),
    boundaries.UNDETERMINED: dict(color="#00e5ff", lw=1.3, label="undetermined boundary (grid too coarse to tell)"),
    # black dashes on yellow: a separatrix and a deadlock in one cell, told from a deadlock (solid black)
    boundaries.SEPARATRIX_AND_DEADLOCK: dict(color="k", lw=2.2, ls=(0, (1.2, 1.0)), gapcolor="#ffff33",
                                             dash_capstyle="butt", label="separatrix, then deadlock, within one cell"),
}
ON_RIM_MARKERS = {  # how the plot marks cells still on the rim at t_max, by on_rim_reason: markers larger than a
    # cell, under the boundary lines (which run through them), so that neither hides the other
    outcomes.ROLLING_TRANSIENT: dict(marker="o", label=r"on the rim at $t_{max}$: rolling, no orbit closed"),
    outcomes.SLIP_ROLL_CYCLING: dict(marker="s", label=r"on the rim at $t_{max}$: slip-roll cycling"),
    outcomes.ONE_SLIP: dict(marker="D", label=r"on the rim at $t_{max}$: after one slip"),
    outcomes.STOPPED_EARLY: dict(marker="X", label="on the rim, run stopped early (status)"),
}
ON_RIM_MARK_FRACTION = 0.02  # mark on-rim cells when they are at most this fraction of a panel (else the grey shows)
ISLAND_STYLES = {  # outlines of the periodic islands of the conservative scenes, drawn in dissipative panels
    # (dashed: a dotted area means a long time on the rim, as in the paper)
    "rolling_only": dict(color="k", lw=1.1, ls="-.", label=r"former periodic region, rolling only ($\mu=\infty$)"),
    "slipping": dict(color="k", lw=1.0, ls="--", label="former periodic region with slipping"),
}


def _line_kw(style: dict) -> dict:
    """matplotlib keywords of a boundary style (the outline becomes a stroke path effect)."""
    from matplotlib import patheffects

    kw = {k: v for k, v in style.items() if k not in ("outline", "label")}
    if style.get("outline"):
        kw["path_effects"] = [patheffects.Stroke(linewidth=style["lw"] + 1.2, foreground=style["outline"]),
                              patheffects.Normal()]
    return kw


def _draw_boundaries(ax, sel, w1, beta) -> set:
    """Draw the boundary curves of one scene (``study.curve_variables``: stored in the file, else traced
    from its outcomes and boundary types), each in the style of its type; returns the types drawn."""
    from matplotlib.collections import LineCollection

    if "boundary_type" not in sel:
        return set()
    found = curves.of_scene(sel, str(sel["scene"].values))
    if found is None:  # a file written before the curves were stored
        found = curves.traced(sel["outcome"].transpose("beta", "omega1").values,
                              sel["boundary_type"].transpose("beta", "omega1").values, beta, w1)
    drawn = set()
    for code, style in BOUNDARY_STYLES.items():
        lines = [points for points, kind in found if kind == code]
        if lines:
            kw = _line_kw(style)
            kw["capstyle"] = kw.pop("dash_capstyle", "round")
            ax.add_collection(LineCollection(lines, zorder=4, label=style["label"], gid=f"boundary_{code}",
                                             joinstyle="round", **kw))
            drawn.add(code)
    return drawn


PALETTE = P.OUTCOME_PALETTE  # the one outcome palette of every outcome figure
STAR = P.STAR  # the steady motion's marker



def _small_region(mask, fraction: float = 0.08):
    """(row slice, column slice) of a small region of ``mask`` with a margin, or None if empty or large."""
    if not mask.any():
        return None
    rows, cols = np.nonzero(mask.any(1))[0], np.nonzero(mask.any(0))[0]
    h, w = rows[-1] - rows[0] + 1, cols[-1] - cols[0] + 1
    if h > fraction * mask.shape[0] or w > fraction * mask.shape[1]:
        return None
    pad_r, pad_c = max(2, h), max(2, w)
    return (slice(max(rows[0] - pad_r, 0), rows[-1] + pad_r + 1), slice(max(cols[0] - pad_c, 0), cols[-1] + pad_c + 1))


def _on_rim_marks(ax, sel, w1, beta, extras, size: float) -> None:
    """Mark the cells still on the rim at t_max (a few, next to the boundary lines that would hide
    their grey) with a marker per ``on_rim_reason``, larger than a cell and under the lines."""
    out = sel["outcome"].transpose("beta", "omega1").values
    on = out == outcomes.ON_RIM_AT_T_MAX
    if not on.any() or on.sum() > ON_RIM_MARK_FRACTION * on.size:
        return
    if "on_rim_reason" in sel:
        reason = sel["on_rim_reason"].transpose("beta", "omega1").values
    else:  # files written before on_rim_reason was stored
        def get(name):
            return sel[name].transpose("beta", "omega1").values
        reason = outcomes.on_rim_reason(out, get("status"), get("slip_phases"))
    for code, style in ON_RIM_MARKERS.items():
        i, j = np.nonzero(on & (reason == code))
        if i.size:
            kw = dict(ls="", ms=size, mfc=PALETTE.colour(outcomes.ON_RIM_AT_T_MAX), mec="k", mew=0.5, zorder=3.5)
            ax.plot(w1[j], beta[i], marker=style["marker"], gid=f"on_rim_{code}", **kw)
            extras[f"on_rim_{code}"] = Line2D([], [], marker=style["marker"], label=style["label"], **dict(kw, ms=6))


def _outline_islands(ax, islands, w1, beta, extras) -> None:
    """Outline the periodic islands of the conservative scenes (dissipative panels)."""
    for island, mask in islands.items():
        if mask is None or not mask.any():
            continue
        style = ISLAND_STYLES[island]
        ax.contour(w1, beta, mask.astype(float), levels=[0.5], colors=style["color"], linewidths=style["lw"],
                   linestyles=style["ls"], zorder=6)  # above the star
        extras[f"island_{island}"] = Line2D([], [], **style)


def _panel(ax, sel, w1, beta, b0, islands, extras, labels=True, star_size=None) -> tuple[set, set]:
    """Draw one scene (outcomes, typed boundaries, star, on-rim marks, the outlines of the periodic
    islands ``{island: mask}`` in dissipative scenes, time contours); returns (outcome codes drawn,
    boundary types drawn)."""
    cmap, norm = PALETTE.cmap_norm()
    out = sel["outcome"].transpose("beta", "omega1").values
    ax.pcolormesh(w1, beta, out, cmap=cmap, norm=norm, shading="nearest", rasterized=True)
    kinds = _draw_boundaries(ax, sel, w1, beta)
    _on_rim_marks(ax, sel, w1, beta, extras, size=3.0 if star_size is None else 4.0)
    ax.set_xlim(*P.grid_limits(w1))
    ax.set_ylim(*P.grid_limits(beta))
    if b0 is not None and beta.min() <= b0 <= beta.max() and w1.min() <= 0.0 <= w1.max():
        ax.plot([0.0], [b0], **(STAR if star_size is None else dict(STAR, ms=star_size, mew=1.0)))
        extras["star"] = Line2D([], [], **dict(STAR, label="steady motion (48)"))
    if float(sel["k_r"]) != 0 or float(sel["k_d"]) != 0:
        _outline_islands(ax, islands, w1, beta, extras)
        _time_on_rim(ax, sel, w1, beta, b0, extras, labels)
    return set(np.unique(out).tolist()), kinds


def _time_on_rim(ax, sel, w1, beta, b0, extras, labels: bool) -> None:
    """How long a dissipative scene keeps the ball on the rim (``study.plotting.time_on_rim``)."""
    t_end = sel["t_end"].transpose("beta", "omega1").values
    extras.update(P.time_on_rim(ax, w1, beta, t_end, float(sel["t_max"]), b0, labels))


def _zoom(ax, sel, w1, beta, b0, islands, extras, region) -> None:
    """An inset (upper right) magnifying a small periodic or former periodic region, so that it
    stays visible under the star and the lines."""
    rs, cs = region
    inset = ax.inset_axes([0.6, 0.58, 0.38, 0.38])
    part = sel.isel(beta=rs, omega1=cs)
    _panel(inset, part, w1[cs], beta[rs], b0, {k: m[rs, cs] for k, m in islands.items()}, extras, star_size=7)
    inset.tick_params(labelsize=6, length=2)
    inset.set_xlabel(r"$\omega_1$ [1/s]", fontsize=6.5, labelpad=1)
    inset.set_ylabel(r"$\beta$ [rad]", fontsize=6.5, labelpad=1)
    inset.set_title("zoom", fontsize=7, pad=2)
    ax.indicate_inset_zoom(inset, edgecolor="k", lw=0.8)


def _islands(ds) -> dict:
    """{island: (beta, omega1) mask} of the periodic islands, from ``former_periodic`` (or the outcomes)."""
    if "former_periodic" in ds:
        flags = ds["former_periodic"].isel(scene=0).transpose("beta", "omega1").values
    else:  # files written before former_periodic was stored
        conservative = (ds["k_r"].values == 0) & (ds["k_d"].values == 0)
        flags, _ = former_periodic(ds["outcome"].transpose("scene", "beta", "omega1").values, ds["mu"].values,
                                   conservative)
    return {island: (flags & (1 << bit)).astype(bool) for bit, island in enumerate(ISLANDS)}


def _plot(ds):
    fig = Figure(figsize=(11.0, 9.0), layout="constrained")
    axes = fig.subplots(2, 2, sharex=True, sharey=True)
    w1 = ds["omega1"].values
    beta = ds["beta"].values
    p = params_of(ds)
    omega2, omega3 = float(setting_of(ds, "omega2")), float(setting_of(ds, "omega3"))
    b0 = steady_beta0(omega2, omega3, p, beta.min(), beta.max())
    codes, kinds = set(), set()
    extras = {}
    islands = _islands(ds)
    for k, ax in enumerate(axes.flat[: ds.sizes["scene"]]):
        sel = ds.isel(scene=k)
        conservative = float(sel["k_r"]) == 0 and float(sel["k_d"]) == 0
        periodic = sel["outcome"].transpose("beta", "omega1").values == outcomes.PERIODIC_ROLLING
        small_island = islands["slipping"] if islands["slipping"].any() else islands["rolling_only"]
        small = _small_region(periodic if conservative else small_island | periodic)
        # a small region gets a zoom, which then carries the time labels (the panel stays clear)
        c, t = _panel(ax, sel, w1, beta, b0, islands, extras, labels=small is None)
        codes, kinds = codes | c, kinds | t
        if small is not None:
            _zoom(ax, sel, w1, beta, b0, islands, extras, small)
        ax.set_title(P.scene_title(sel), fontsize=10)
    for ax in axes[1]:
        ax.set_xlabel(r"initial transversal angular velocity $\omega_1$ [1/s]")
    for ax in axes[:, 0]:
        ax.set_ylabel(r"initial height angle $\beta$ [rad]")
    handles = PALETTE.handles(codes)
    handles += [Line2D([], [], **_line_kw(BOUNDARY_STYLES[c]), label=BOUNDARY_STYLES[c]["label"])
                for c in BOUNDARY_STYLES if c in kinds]
    handles += [extras[f"on_rim_{c}"] for c in ON_RIM_MARKERS if f"on_rim_{c}" in extras]
    handles += [extras[key] for key in ("star", "time", "long", "island_rolling_only", "island_slipping")
                if key in extras]
    fig.legend(handles=handles, loc="outside lower center", ncol=3, fontsize=9, frameon=False)
    fig.suptitle(rf"{ds.attrs['title']}: $\omega_2={omega2:g}$ 1/s, $\omega_3={omega3:g}$ 1/s", fontsize=11)
    return fig


DERIVED_DOCS = (
    ("boundary_type", "1", "kind of boundary of periodic rolling at this cell, each boundary pair refined by "
     "simulation ([outcome-studies.md](outcome-studies.md#outputs))"),
    (("boundary_omega1", "boundary_beta"), "1/s, rad", "the points of the boundary curves between outcome regions "
     "(polylines through the cell-edge midpoints), the curves one after the other along boundary_point "
     "([outcome-studies.md](outcome-studies.md#boundary-curves))"),
    (("boundary_node_count", "boundary_curve_type", "boundary_curve_scene", "boundary_curve_outcome_a",
      "boundary_curve_outcome_b"), "1", "per boundary curve: its number of points, its boundary type, scene and "
     "the two outcomes it separates ([outcome-studies.md](outcome-studies.md#boundary-curves))"),
    ("n_simulated", "1", "trajectories simulated per scene (an adaptive map: the cells with refine_level >= 0; "
     "[outcome-studies.md](outcome-studies.md#adaptive-maps))"),
    ("former_periodic", "1", "the periodic islands of the conservative scenes (rolling only, slipping); "
     "attributes: what each dissipative scene does with each island's states, counts and fractions "
     "([outcome-studies.md](outcome-studies.md#outputs))"),
)
"""The variables ``_derive`` adds, as docs/studies.md lists them."""
REFERENCE = ReferenceSpec({"beta": 24, "omega1": 36}, precise={"rtol": 1e-12, "atol": 1e-14, "method": "dop853"})
"""The reference slices: a 24 x 36 sub-grid of each section in all four scenes, at the engine's
tightest setting (DOP853, rtol 1e-12)."""

for _name, _omega2, _fig in FIGURES:
    register(Study(
        name=_name,
        title=f"Outcome of a ball on the rim (paper Fig. {_fig})",
        settings={**SETTINGS, "omega2": _omega2, **ADAPTIVE_SETTINGS},
        quick=QUICK,
        axes=adaptive_axes(section_axes),
        variables=VARIABLES,
        compute=_compute,
        plot=_plot,
        chunks=_chunks,
        derive=_derive,
        derived_docs=DERIVED_DOCS,
        ignores=SCENE_IGNORES,
        # cost: seconds per grid point on one core, warm (--quick on 2 shared cores, 2026-11)
        cost=3e-4, compiles=True, cost_factor=adaptive_cost_factor,
        reference=REFERENCE,
    ))
