"""Continuation in a parameter: the outcome fractions of a (beta, omega1) section followed along omega2.

``continuation`` sweeps omega2 from 20 to 120 1/s (by default; ``--set`` sweeps mu, omega3, rho_over_R,
j, k_r or k_d instead or too) and computes, at each value, the outcome map of the section of Figs.
11-13 (adaptive by default, ``solver.analysis.adaptive_map``) and from it, once the whole cube is assembled:

- ``fraction_fall_in``, ``fraction_fall_out``, ``fraction_periodic``, ``fraction_on_rim``: the
  share of the section's initial states with each outcome;
- ``island_count`` and ``island_area``: the periodic islands (4-connected regions of periodic
  rolling) and their total area [rad s-1];
- ``island_event``: where along the first swept axis an island is born (none before), splits (more
  than before), merges (fewer, not none) or vanishes (none after some);
- the steady motion (47)-(48) with omega20 = omega2 and omega30 = omega3: ``steady_beta0`` (NaN if
  none), its stability h (54) ``steady_h``, the friction it needs to roll ``steady_friction`` (56) and
  its realisable region of Fig. 8 ``steady_region`` (A, B, C or none, with the setting v_throw).
"""

from __future__ import annotations

import numpy as np
from matplotlib.figure import Figure
from matplotlib.ticker import MaxNLocator
from scipy import ndimage

from rimroll import solver
from rimroll.solver.analysis import steady
from rimroll.solver.engine import outcomes
from rimroll.solver.physics.params import TERM_KEYS
from rimroll.study import cubeplots as C
from rimroll.study import outcome_sections as sections
from rimroll.study import plotting as P
from rimroll.study.dataset import params_of, setting_of
from rimroll.study.outcome_sections import BETA_COMMENT, OMEGA1_COMMENT, steady_beta0
from rimroll.study.registry import Axis, ReferenceSpec, Study, Var, output_var, register

SWEEPS = ("omega2", "mu", "omega3", "rho_over_R", "j", *TERM_KEYS)
PAPER_OMEGA2 = (35.0, 65.0, 105.0)
"""The omega2 [1/s] of the paper's sections (Figs. 11-13): vertical lines in the plot."""
FRACTIONS = (("fall_in", (outcomes.FALL_IN,)), ("fall_out", (outcomes.FALL_OUT,)),
             ("periodic", (outcomes.PERIODIC_ROLLING,)), ("on_rim", (outcomes.ON_RIM_AT_T_MAX, outcomes.STEADY_MOTION)))
BORN, SPLIT, MERGED, VANISHED = 1, 2, 4, 8
EVENTS = {BORN: "born", SPLIT: "split", MERGED: "merged", VANISHED: "vanished"}
"""Bit flags of ``island_event`` (CF flag_masks): several may happen between two values."""


def _axes(s: dict) -> list[Axis]:
    if s["n_beta"] < 2 or s["n_omega1"] < 2:
        raise ValueError(f"n_beta and n_omega1 must be >= 2; got {s['n_beta']}, {s['n_omega1']}")
    w = float(s["omega1_max"])
    return [Axis("beta", np.linspace(s["beta_min"], s["beta_max"], int(s["n_beta"])), "rad", "initial height angle",
                 comment=BETA_COMMENT),
            Axis("omega1", np.linspace(-w, w, int(s["n_omega1"])), "s-1", "initial omega1", comment=OMEGA1_COMMENT)]


def _compute(coords, p, s):
    beta, omega1 = coords

    def run(b, w):
        states = np.stack([b, w, np.full_like(b, s["omega2"]), np.full_like(b, s["omega3"])], axis=-1)
        return solver.simulate(states, p, t_max=s["t_max"], rtol=s["rtol"], atol=s["atol"], method=s["method"],
                               workers=1, backend=s["backend"])
    res = sections.map_section(run, beta, omega1, s, p.m * p.g, keep=("outcome", "status"))
    return {name: res[name] for name in ("outcome", "status", "refine_level")}


def islands(periodic: np.ndarray) -> tuple[int, int]:
    """(number, cells) of the 4-connected regions of a (beta, omega1) mask."""
    _, n = ndimage.label(periodic)
    return int(n), int(periodic.sum())


def island_events(periodic: np.ndarray) -> np.ndarray:
    """Bit flags (:data:`EVENTS`) along axis 0 of periodic masks (n, beta, omega1): at index k, what
    the islands of map k are to those of map k - 1, by overlap on the common grid: born (an island
    overlapping none before), split (one before overlapping several now), merged (one now overlapping
    several before), vanished (one before overlapping none now)."""
    periodic = np.asarray(periodic, dtype=bool)
    events = np.zeros(periodic.shape[0], dtype=np.int8)
    for k in range(1, periodic.shape[0]):
        before, n_before = ndimage.label(periodic[k - 1])
        now, n_now = ndimage.label(periodic[k])
        both = (before > 0) & (now > 0)
        pairs = np.unique(np.stack([before[both], now[both]]), axis=1) if both.any() else np.zeros((2, 0), int)
        per_before = np.bincount(pairs[0], minlength=n_before + 1)[1:]
        per_now = np.bincount(pairs[1], minlength=n_now + 1)[1:]
        events[k] = (BORN * (per_now == 0).any() | SPLIT * (per_before > 1).any()
                     | MERGED * (per_now > 1).any() | VANISHED * (per_before == 0).any())
    return events


def _steady(ds, outer: list) -> dict:
    """The steady motion with omega20 = omega2 at each point of the outer axes."""
    shape = tuple(ds.sizes[d] for d in outer)
    out = {k: np.full(shape, np.nan) for k in ("beta0", "h", "friction")}
    out["region"] = np.zeros(shape, dtype=np.int8)
    for idx in np.ndindex(shape):
        sel = ds.isel(dict(zip(outer, idx)))
        p = params_of(sel)
        w2, w3 = float(setting_of(sel, "omega2")), float(setting_of(sel, "omega3"))
        b0 = steady_beta0(w2, w3, p, 1e-3, np.pi / 2)
        if b0 is None:
            continue
        out["beta0"][idx] = b0
        out["h"][idx] = float(steady.stability(b0, w3, p))
        out["friction"][idx] = float(steady.required_friction(b0, w3, p))
        out["region"][idx] = int(steady.realisable_region(b0, w3, p, float(setting_of(sel, "v_throw"))))
    return out


def _derive(ds) -> dict:
    outer = [d for d in ds["outcome"].dims if d not in ("beta", "omega1")]
    codes = ds["outcome"].transpose(*outer, "beta", "omega1").values
    cells = np.abs(np.gradient(ds["beta"].values)).mean() * np.abs(np.gradient(ds["omega1"].values)).mean()
    out = {}
    for name, values in FRACTIONS:
        out[f"fraction_{name}"] = (tuple(outer), np.isin(codes, values).mean(axis=(-2, -1)), {
            "units": "1", "long_name": f"fraction of the section's initial states: {name.replace('_', ' ')}"})
    shape = codes.shape[:-2]
    count, area = np.zeros(shape, dtype=np.int32), np.zeros(shape)
    for idx in np.ndindex(shape):
        n, c = islands(codes[idx] == outcomes.PERIODIC_ROLLING)
        count[idx], area[idx] = n, c * cells
    out["island_count"] = (tuple(outer), count, {"units": "1", "long_name": "number of periodic islands "
                                                 "(4-connected regions of periodic rolling in the section)"})
    out["island_area"] = (tuple(outer), area, {"units": "rad s-1", "long_name": "area of the periodic islands"})
    events = np.zeros(shape, dtype=np.int8)
    if outer:  # along the first swept axis, at every point of the others
        moved = np.moveaxis(codes == outcomes.PERIODIC_ROLLING, 0, -3)
        for idx in np.ndindex(moved.shape[:-3]):
            np.moveaxis(events, 0, -1)[idx] = island_events(moved[idx])
    out["island_event"] = (tuple(outer), events, {
        "units": "1", "long_name": "change of the periodic islands from the previous value of the first swept axis",
        "flag_masks": np.array(tuple(EVENTS), dtype="int8"), "flag_meanings": " ".join(EVENTS.values()),
        "comment": "by overlap of the islands of consecutive maps on the common grid (0: no change)",
        "rimroll_compared": 0})  # flags along the swept axis only: `study verify` compares the outcomes they come from
    st = _steady(ds, outer)
    out["steady_beta0"] = (tuple(outer), st["beta0"], {"units": "rad", "long_name": "beta0 of the steady motion "
                                                       "(48) with omega20 = omega2, omega30 = omega3 (NaN: none)"})
    out["steady_h"] = (tuple(outer), st["h"], {"units": "s-2", "long_name": "h (54) of that steady motion "
                                               "(< 0 stable)"})
    out["steady_friction"] = (tuple(outer), st["friction"], {"units": "1", "long_name": "friction coefficient that "
                                                             "steady motion needs to roll (56)"})
    out["steady_region"] = (tuple(outer), st["region"], {
        "units": "1", "long_name": "realisable region of that steady motion (Fig. 8), with the setting v_throw",
        "flag_values": np.array(steady.REGION_FLAG_VALUES, dtype="int8"), "flag_meanings": steady.REGION_FLAG_MEANINGS,
        "rimroll_compared": 0})  # a closed form (steady.realisable_region), no simulation to verify
    return out


def _plot(ds):
    outer = C.swept(ds)
    if not outer:
        fig = Figure(figsize=(6.0, 4.0), layout="constrained")
        fig.add_subplot().text(0.5, 0.5, "one point: nothing to continue\n(sweep omega2, mu, ...)", ha="center")
        return fig
    x = outer[0]
    rest = {d: 0 for d in outer[1:]}
    sel = ds.isel(rest) if rest else ds
    xs = sel[x].values
    fig = Figure(figsize=(9.0, 6.5), layout="constrained")
    ax, bx = fig.subplots(2, 1, sharex=True, height_ratios=(2.2, 1.0))
    for name, values in FRACTIONS:
        ax.plot(xs, sel[f"fraction_{name}"].values, "-o", ms=2.5, color=P.OUTCOME_PALETTE.colour(values[0]),
                label=P.OUTCOME_PALETTE.label(values[0]))
    ev = sel["island_event"].values
    for code, marker in ((BORN, "^"), (SPLIT, "v"), (MERGED, "s"), (VANISHED, "x")):
        hit = (ev & code) != 0
        if hit.any():
            ax.plot(xs[hit], sel["fraction_periodic"].values[hit], marker, ms=9, mfc="none", mec="k", ls="",
                    label=f"island {EVENTS[code]}")
    bx.step(xs, sel["island_count"].values, where="mid", color="k", label="periodic islands")
    left = np.flatnonzero(np.diff((sel["steady_region"].values == steady.REGION_A).astype(int)) != 0)
    for k in left:
        for a in (ax, bx):
            a.axvline(0.5 * (xs[k] + xs[k + 1]), color="tab:red", lw=1.0, ls=":")
    if left.size:
        bx.plot([], [], color="tab:red", ls=":", label="steady motion (48) enters/leaves region A")
    if x == "omega2":
        for w in PAPER_OMEGA2:
            for a in (ax, bx):
                a.axvline(w, color="0.5", lw=0.8, ls="--")
        ax.plot([], [], color="0.5", ls="--", label="the paper's sections (Figs. 11-13)")
    C.fraction_scale(ax, [sel[f"fraction_{name}"].values for name, _ in FRACTIONS])  # a small one visible
    ax.set_ylabel("fraction of the initial states [-]")
    bx.set_ylabel("islands [-]")
    bx.set_xlabel(C.axis_label(ds, x))
    ax.legend(fontsize=8, ncol=2)
    bx.legend(fontsize=8)
    held = C.held_text(sel, SWEEPS, fig, 11)
    fig.suptitle(f"Outcome fractions continued in {x}" + (f"\nat {held}" if held else ""), fontsize=11)
    bx.yaxis.set_major_locator(MaxNLocator(integer=True))  # a count of islands
    return fig


DERIVED_DOCS = (
    (("fraction_fall_in", "fraction_fall_out", "fraction_periodic", "fraction_on_rim"), "1",
     "share of the section's initial states with each outcome (on_rim: still on the rim at t_max or steady)"),
    ("island_count", "1", "periodic islands: 4-connected regions of periodic rolling"),
    ("island_area", "rad s-1", "their total area"),
    ("island_event", "1", "bit flags along the first swept axis (flag_masks): born, split, merged, vanished"),
    (("steady_beta0", "steady_h", "steady_friction", "steady_region"), "rad, s-2, 1, 1",
     "the steady motion (48) with omega20 = omega2: beta0, h (54), friction to roll (56), region of Fig. 8"),
)

register(Study(
    name="continuation",
    title="Outcome fractions and periodic islands of the Figs. 11-13 section continued in omega2",
    settings={"omega2": tuple(float(v) for v in np.linspace(20.0, 120.0, 51)), "omega3": 10.0, "mu": np.inf,
              "beta_min": 0.8, "beta_max": 1.8, "n_beta": 120, "omega1_max": 20.0, "n_omega1": 180,
              "t_max": 20.0, "rtol": 1e-8, "atol": 1e-10, "method": "auto", "backend": "cpu", "v_throw": 10.0,
              **sections.ADAPTIVE_SETTINGS, "adaptive": True},
    quick={"omega2": (20.0, 35.0, 50.0, 65.0, 85.0, 105.0, 120.0), "n_beta": 24, "n_omega1": 36,
           "adaptive_coarse": 4},
    sweepable=SWEEPS,
    cost=3e-5, compiles=True, cost_factor=sections.adaptive_cost_factor,
    axes=sections.adaptive_axes(_axes),
    variables=[output_var(name) for name in ("outcome", "status")] + [
        Var("refine_level", "1", sections.LEVEL_ATTRS["long_name"], dtype="int8",
            comment=sections.LEVEL_ATTRS["comment"], compared=False)],
    compute=_compute,
    chunks=lambda s: sections.adaptive_chunks(s, {}),
    derive=_derive,
    derived_docs=DERIVED_DOCS,
    plot=_plot,
    # a 12 x 18 sub-grid of the full map (adaptive=false) at the paper's three sections, DOP853 at rtol 1e-12:
    # `study verify` of an adaptive file then checks its outcomes against simulated ones
    reference=ReferenceSpec({"beta": 12, "omega1": 18},
                            precise={"rtol": 1e-12, "atol": 1e-14, "method": "dop853", "adaptive": False},
                            sets={"omega2": (35, 65, 105)}),
))
