"""Parametric cubes: what the paper held fixed, swept.

- ``realisable-cube``: the realisable steady motions of Fig. 8 over
  mu x v_throw x j x rho_over_R x beta0 x omega30, from ``solver.steady.realisable_region``;
  stores the region label of every point and, per (mu, v_throw, j, rho_over_R), the area of
  regions A, B and C in the (beta0, omega30) plane [rad s-1].
- ``outcome-cube``: outcomes of rolling initial states (Figs. 11-13 at reduced resolution) over
  mu x k_r x k_d x omega2 x beta x omega1, from ``solver.simulate``: outcome, t_end, revolutions.

Both are ordinary studies whose ``sweepable`` settings hold tuples by default; ``--set KEY=...``
changes the values (or a scalar removes the axis; ``--set mu=1,inf`` puts slipping and rolling
only on one axis). One chunk = one outer point (whole grid). Their figures show every swept
axis (``study.cubeplots``): the areas or the outcome fractions against each, and the section's
map of each slice when there are few; ``study plot FILE --select`` of every swept axis draws the
map of that slice alone, as Fig. 8 (realisable regions) or Figs. 11-13 (outcomes) draw theirs.
"""

from __future__ import annotations

import numpy as np
from matplotlib.figure import Figure
from matplotlib.lines import Line2D

from rimroll import solver
from rimroll.solver.analysis import adaptive_map, steady
from rimroll.solver.physics.params import TERM_KEYS
from rimroll.study import cubeplots as C
from rimroll.study import outcome_sections as sections
from rimroll.study import plotting as P
from rimroll.study.dataset import params_of, setting_of
from rimroll.study.outcome_sections import BETA_COMMENT, OMEGA1_COMMENT, steady_beta0
from rimroll.study.registry import Axis, ReferenceSpec, Study, Var, output_var, register

STANDARD = solver.Params()
STANDARD_RHO_OVER_R = STANDARD.rho / STANDARD.R  # 0.5778: the ball of Table 1


def _cell_sizes(values: np.ndarray) -> np.ndarray:
    """Width of the cell around each grid point (uniform grids: the spacing)."""
    return np.abs(np.gradient(values)) if values.size > 1 else np.ones(1)


# ================================================================ realisable-cube
def _realisable_axes(s: dict) -> list[Axis]:
    if s["n_beta0"] < 2 or s["n_omega30"] < 2 or not s["omega30_max"] > 0:
        raise ValueError("n_beta0 and n_omega30 must be >= 2 and omega30_max > 0")
    w = s["omega30_max"]
    return [Axis("beta0", np.linspace(-np.pi, np.pi, s["n_beta0"], endpoint=False), "rad", "steady height angle",
                 comment="height angle of the steady motion on the rim's minor circle"),
            Axis("omega30", np.linspace(-w, w, s["n_omega30"]), "s-1", "steady omega3",
                 comment="circular angular velocity of the steady motion")]


def _realisable_compute(coords, p, s):
    beta0, omega30 = coords
    region = steady.realisable_region(beta0, omega30, p, s["v_throw"])
    cells = np.outer(_cell_sizes(beta0[:, 0]), _cell_sizes(omega30[0, :]))
    areas = {f"area_{name}": float(cells[region == code].sum())
             for name, code in (("A", steady.REGION_A), ("B", steady.REGION_B), ("C", steady.REGION_C))}
    return {"region": region, **areas}


REALISABLE_SWEEPS = ("mu", "v_throw", "j", "rho_over_R")
OUTCOME_SWEEPS = ("mu", *TERM_KEYS, "omega2", "omega3", "j", "rho_over_R")  # every term's strength


def _realisable_plot(ds):
    """Areas of A, B, C against every swept axis, with the region map of each of a few slices; a
    slice held on every swept axis (``study plot FILE --select ...``): its region map, as Fig. 8."""
    if not C.swept(ds):
        return _realisable_slice(ds)
    picks = C.slices(ds, C.swept(ds))
    picks = picks if len(picks) <= C.MAX_MAPS else []
    fig, panels, maps = C.layout(ds, len(picks))
    series = [(f"region {name}", ds[f"area_{name}"], P.REGION_LINE_COLOURS[code])
              for name, code in (("A", steady.REGION_A), ("B", steady.REGION_B), ("C", steady.REGION_C))]
    handles = C.sweep_panels(panels, ds, series, r"area in the ($\beta_0$, $\omega_{30}$) plane [rad/s]")
    for ax, pick in zip(maps, picks):
        _region_panel(ax, ds.isel(pick), small=True)
        ax.set_title(C.slice_text(ds, pick), fontsize=9)
    fig.legend(handles=handles, loc="outside lower center", ncol=3, fontsize=9, frameon=False)
    held = C.held_text(ds, REALISABLE_SWEEPS, fig, 11, lead=3)
    fig.suptitle("Realisable steady motions (Fig. 8): areas of regions A, B, C" + (f"\nat {held}" if held else "")
                 + ("\nbelow: the map of each slice" if picks else f"\n{C.select_hint(ds)}"), fontsize=11)
    return fig


def _region_panel(ax, sel, small: bool = False) -> None:
    """The Fig. 8 map of one slice of the cube (omega20 from (48) with the slice's parameters)."""
    p = params_of(sel)
    b, w, region = P.plane(sel, "region")
    B, W = np.meshgrid(b, w)
    w20 = steady.omega20(B, W, p)
    letters = dict(zip(steady.REGION_FLAG_VALUES, sel["region"].attrs["flag_meanings"].split()))
    P.beta_omega_axes(ax, sel, "")
    P.region_map(ax, b, w, region, w20, letters, fontsize=9 if small else 15)
    if small:
        ax.xaxis.label.set_fontsize(8)
        ax.yaxis.label.set_fontsize(8)
        ax.tick_params(labelsize=7)


def _realisable_slice(ds):
    fig, ax = P.new_figure()
    _region_panel(ax, ds)
    areas = ", ".join(f"{name} {float(ds[f'area_{name}']):.3g}" for name in "ABC")
    ax.set_title(f"Realisable steady motions (Fig. 8) at {C.held_text(ds, REALISABLE_SWEEPS)}\n"
                 rf"$\pm$: sign of $\omega_{{20}}$, dotted: $\omega_{{20}}=0$; areas [rad/s]: {areas}", fontsize=10)
    return fig


def _area(name):
    # a sum over the whole (beta0, omega30) grid: compared with a reference on its own grid only
    return Var(f"area_{name}", "rad s-1", f"area of realisable region {name} of Fig. 8 in the "
               "(beta0, omega30) plane", outer=True, pointwise=False)


register(Study(
    name="realisable-cube",
    title="Realisable steady motions (Fig. 8) over mu x v_throw x j x rho/R, with areas of A, B, C",
    settings={"mu": (0.5, 1.0, 2.0), "v_throw": (1.0, 3.0, 5.0, 7.0, 10.0),
              "j": (0.4, 0.5333333333333333, 2.0 / 3.0), "rho_over_R": (0.45, STANDARD_RHO_OVER_R, 0.7),
              "n_beta0": 721, "n_omega30": 560, "omega30_max": 70.0},
    quick={"mu": (0.5, 1.0), "v_throw": (3.0, 7.0, 10.0), "j": (0.5, 2.0 / 3.0),
           "rho_over_R": (0.45, STANDARD_RHO_OVER_R), "n_beta0": 121, "n_omega30": 80},
    sweepable=REALISABLE_SWEEPS,
    ignores={k: "the realisable regions are those of the conservative rolling equations (closed forms)"
             for k in TERM_KEYS},
    cost=1e-6,  # seconds per grid point on one core, warm (--quick on 2 shared cores, 2026-11)
    axes=_realisable_axes,
    variables=[Var("region", "1", "region of the realisable steady motion (Fig. 8): stable (54), rolling "
                   "(56), within the throw energy (59)", dtype="int8",
                   flag_values=steady.REGION_FLAG_VALUES, flag_meanings=steady.REGION_FLAG_MEANINGS),
               _area("A"), _area("B"), _area("C")],
    compute=_realisable_compute,
    plot=_realisable_plot,
    # closed forms: the slices are exact; the default one holds mu = 0.5, 2 and v_throw = 3, 10 at the
    # standard ball, on a 121 x 80 sub-grid of (beta0, omega30)
    reference=ReferenceSpec({"beta0": 121, "omega30": 80},
                            sets={"mu": (0.5, 2), "v_throw": (3, 10), "j": 0.6666666666666666,
                                  "rho_over_R": STANDARD_RHO_OVER_R}),
))


# ================================================================ outcome-cube
PALETTE = P.OUTCOME_PALETTE  # the one outcome palette (same colours and words as fig11-13)


def _outcome_axes(s: dict) -> list[Axis]:
    if s["n_beta"] < 2 or s["n_omega1"] < 2:
        raise ValueError(f"n_beta and n_omega1 must be >= 2; got {s['n_beta']}, {s['n_omega1']}")
    return [Axis("beta", np.linspace(0.8, 1.8, s["n_beta"]), "rad", "initial height angle", comment=BETA_COMMENT),
            Axis("omega1", np.linspace(-20.0, 20.0, s["n_omega1"]), "s-1", "initial omega1", comment=OMEGA1_COMMENT)]


def _outcome_compute(coords, p, s):
    beta, omega1 = coords

    def run(b, w):
        states = np.stack([b, w, np.full_like(b, s["omega2"]), np.full_like(b, s["omega3"])], axis=-1)
        return solver.simulate(states, p, t_max=s["t_max"], rtol=s["rtol"], atol=s["atol"], method=s["method"],
                               workers=1, backend=s["backend"], **sections.engine_options(s))
    res = sections.map_section(run, beta, omega1, s, p.m * p.g, keep=("outcome", "t_end", "revolutions", "status"))
    return {name: res[name] for name in ("outcome", "t_end", "revolutions", "status", "refine_level")}


def _outcome_derive(ds) -> dict:
    """``n_simulated``: the trajectories simulated for each slice's map (``solver.analysis.adaptive_map``)."""
    if "refine_level" not in ds:  # files written before adaptive maps have none
        return {}
    dims = tuple(d for d in ds["refine_level"].dims if d not in ("beta", "omega1"))
    counts = adaptive_map.n_simulated(ds["refine_level"].transpose(*dims, "beta", "omega1").values)
    return {"n_simulated": (dims, np.asarray(counts, dtype=np.int32), {
        "units": "1", "long_name": "trajectories simulated for the map of this slice (initial states)",
        "comment": "a full map: every cell; an adaptive map (setting adaptive = 1): the cells with refine_level >= 0"})}


def _outcome_plot(ds):
    """Outcome fractions over the section against every swept axis, with the outcome map of each
    of a few slices; a slice held on every swept axis: its outcome map, as Figs. 11-13."""
    if not C.swept(ds):
        return _outcome_slice(ds)
    picks = C.slices(ds, C.swept(ds))
    picks = picks if len(picks) <= C.MAX_MAPS else []
    fig, panels, maps = C.layout(ds, len(picks))
    outcome = ds["outcome"].load()
    codes = [int(c) for c in np.unique(outcome.values)]  # the outcomes that occur: one curve each
    series = [(PALETTE.label(c), (outcome == c).mean(("beta", "omega1")), PALETTE.colour(c)) for c in codes]
    handles = C.sweep_panels(panels, ds, series, r"fraction of the initial states ($\beta$, $\omega_1$) [-]",
                             ylim=(-0.02, 1.02))
    extras = {}
    for ax, pick in zip(maps, picks):
        extras.update(_section_panel(ax, ds.isel(pick), small=True))
        ax.set_title(C.slice_text(ds, pick), fontsize=9)
    handles += [extras[k] for k in ("star", "time", "long") if k in extras]
    fig.legend(handles=handles, loc="outside lower center", ncol=3, fontsize=9, frameon=False)
    held = C.held_text(ds, OUTCOME_SWEEPS, fig, 11, lead=3)
    fig.suptitle("Outcomes of rolling initial states over the section (Figs. 11-13)" + (f"\nat {held}" if held else "")
                 + ("\nbelow: the map of each slice" if picks else f"\n{C.select_hint(ds)}"), fontsize=11)
    return fig


def _section_panel(ax, sel, small: bool = False) -> bool:
    """The outcome map of one slice over (omega1, beta) with its steady motion (48) as a star and, when
    dissipative, its time on the rim; returns the legend handles of what it drew beside the outcomes."""
    p = params_of(sel)
    w1, beta = sel["omega1"].values, sel["beta"].values
    omega2, omega3 = float(setting_of(sel, "omega2")), float(setting_of(sel, "omega3"))
    b0 = steady_beta0(omega2, omega3, p, beta.min(), beta.max())
    P.outcome_map(ax, w1, beta, sel["outcome"].transpose("beta", "omega1").values, b0,
                  star_size=7 if small else None)
    extras = {}
    if p.dissipative:
        extras = P.time_on_rim(ax, w1, beta, sel["t_end"].transpose("beta", "omega1").values,
                               float(setting_of(sel, "t_max")), b0, labels=not small)
    ax.set_xlabel(r"initial $\omega_1$ [1/s]", fontsize=8 if small else 10)
    ax.set_ylabel(r"initial $\beta$ [rad]", fontsize=8 if small else 10)
    if small:
        ax.tick_params(labelsize=7)
    if b0 is not None and beta.min() <= b0 <= beta.max():
        extras["star"] = Line2D([], [], **dict(P.STAR, label="steady motion (48)"))
    return extras


def _outcome_slice(ds):
    fig = Figure(figsize=(8.5, 6.4), layout="constrained")
    ax = fig.add_subplot()
    extras = _section_panel(ax, ds)
    codes = np.unique(ds["outcome"].values)
    handles = PALETTE.handles(codes) + [extras[k] for k in ("star", "time", "long") if k in extras]
    fig.legend(handles=handles, loc="outside lower center", ncol=3, fontsize=9, frameon=False)
    ax.set_title(f"Outcome of a ball on the rim (as Figs. 11-13)\nat {C.held_text(ds, OUTCOME_SWEEPS)}", fontsize=10)
    return fig


register(Study(
    name="outcome-cube",
    title="Outcomes of rolling initial states (Figs. 11-13, reduced grid) over mu x k_r x k_d x omega2",
    settings={"mu": (0.5, 1.0, 2.0), "k_r": (0.0, 0.01, 0.02), "k_d": (0.0, 0.01, 0.02),
              "omega2": (35.0, 65.0, 105.0), "omega3": 10.0, "n_beta": 36, "n_omega1": 60,
              "t_max": 20.0, "rtol": 1e-6, "atol": 1e-9, "method": "auto", "backend": "cpu",
              **sections.ADAPTIVE_SETTINGS,
              "delta": sections.SETTINGS["delta"], "slip_method": sections.SETTINGS["slip_method"]},
    quick={"mu": (0.5, 1.0), "k_r": (0.0, 0.02), "k_d": (0.0, 0.02), "omega2": (65.0, 105.0),
           "n_beta": 12, "n_omega1": 18},
    sweepable=OUTCOME_SWEEPS,
    # cost: seconds per grid point on one core, warm (--quick on 2 shared cores, 2026-11)
    cost=2e-4, compiles=True, cost_factor=sections.adaptive_cost_factor,
    axes=sections.adaptive_axes(_outcome_axes),
    variables=[output_var(name) for name in ("outcome", "t_end", "revolutions", "status")] + [
        Var("refine_level", "1", sections.LEVEL_ATTRS["long_name"], dtype="int8",
            comment=sections.LEVEL_ATTRS["comment"], compared=False)],
    compute=_outcome_compute,
    chunks=lambda s: sections.adaptive_chunks(s, {}),  # an adaptive map: the whole (beta, omega1) grid of a slice
    derive=_outcome_derive,
    derived_docs=(("n_simulated", "1", "trajectories simulated per slice (an adaptive map: the cells with "
                   "refine_level >= 0; [outcome-studies.md](outcome-studies.md#adaptive-maps))"),),
    plot=_outcome_plot,
    # the default slice: mu = 1, 2 and k_r = 0, 0.02 at k_d = 0, omega2 = 65 1/s, on a 12 x 20 sub-grid
    reference=ReferenceSpec({"beta": 12, "omega1": 20}, precise={"rtol": 1e-12, "atol": 1e-14, "method": "dop853"},
                            sets={"mu": (1, 2), "k_r": (0, 0.02), "k_d": 0, "omega2": 65}),
))
