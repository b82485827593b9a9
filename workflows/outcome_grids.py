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
override the run's. Every result field of ``solver.simulate`` is stored, plus
``boundary_type`` (derived once from the whole grid, ``solver.boundaries``): which cells lie on
a boundary of periodic rolling and of which kind (deadlock, separatrix, slipping-induced; paper
Sect. 5.1, 5.2.3). Slipping scenes are compared with the rolling-only scene of the same file.
"""

from __future__ import annotations

import numpy as np
from matplotlib.colors import BoundaryNorm, ListedColormap
from matplotlib.figure import Figure
from matplotlib.lines import Line2D
from matplotlib.patches import Patch
from scipy.optimize import brentq

import solver
from solver import boundaries, outcomes, steady
from study.dataset import params_of, setting_of
from study.registry import Axis, Study, Var, register

SCENES = ("rolling_only", "slipping", "drilling", "rolling_resistance")
"""Labels of the ``scene`` coordinate, in file order."""
SCENE_NAMES = ("rolling only", "slipping", "slipping + drilling resistance", "slipping + rolling resistance")
"""Plot titles of the scenes, in the order of :data:`SCENES`."""
SCENE_TITLES = dict(zip(SCENES, SCENE_NAMES))
OUTCOME_COLOURS = ("#2b8cbe", "#e6550d", "#31a354", "#bdbdbd")  # in, out, periodic, on rim at t_max

SETTINGS = {
    "omega3": 10.0,  # [1/s]
    "beta_min": 0.8, "beta_max": 1.8, "n_beta": 240,  # [rad]
    "omega1_max": 20.0, "n_omega1": 360,  # [1/s], symmetric range
    "mu_slip": 1.0,  # friction of the slipping scenes
    "k_dissipation": 0.02,  # [1/s] rate of the drilling / rolling resistance scenes
    "t_max": 20.0,  # [s] conservative scenes
    "t_max_dissipative": 60.0,  # [s]
    "rtol": 1e-8, "atol": 1e-10, "method": "dp5",
}
QUICK = {"n_beta": 24, "n_omega1": 36}

FLOAT_VARS = [
    Var("t_end", "s", "time of separation from the rim, of periodicity detection, or t_max"),
    Var("f2_min", "N", "smallest normal contact force F2 along the run"),
    Var("half_period", "s", "half period t2 - t1 of periodic rolling (NaN unless periodic)"),
    Var("revolutions", "1", "angle alpha travelled around the rim / 2 pi"),
    Var("slip_time", "s", "total time spent slipping"),
    Var("energy_drift", "1", "relative change of the mechanical energy over the run"),
    Var("beta_end", "rad", "height angle at t_end"),
    Var("omega1_end", "s-1", "transversal angular velocity at t_end"),
    Var("omega2_end", "s-1", "orthogonal angular velocity at t_end"),
    Var("omega3_end", "s-1", "circular angular velocity at t_end"),
]
VARIABLES = [
    Var("outcome", "1", "outcome of the ball on the rim", dtype="int8",
        flag_values=outcomes.OUTCOME_FLAG_VALUES, flag_meanings=outcomes.OUTCOME_FLAG_MEANINGS),
    *FLOAT_VARS,
    Var("slip_phases", "1", "number of slipping phases", dtype="int32"),
    Var("n_steps", "1", "attempted integrator steps", dtype="int64"),
    Var("status", "1", "integration status", dtype="int8", standard_name="status_flag",
        flag_values=outcomes.STATUS_FLAG_VALUES, flag_meanings=outcomes.STATUS_FLAG_MEANINGS),
]


def scene_table(s: dict) -> dict[str, np.ndarray]:
    """mu, k_r, k_d [1/s] and t_max [s] of the four scenes, from the settings."""
    k, mu = s["k_dissipation"], s["mu_slip"]
    return {
        "mu": np.array([np.inf, mu, mu, mu]),
        "k_r": np.array([0.0, 0.0, 0.0, k]),
        "k_d": np.array([0.0, 0.0, k, 0.0]),
        "t_max": np.array([s["t_max"], s["t_max"], s["t_max_dissipative"], s["t_max_dissipative"]]),
    }


def scene_axis(s: dict) -> Axis:
    """The ``scene`` axis: string labels :data:`SCENES`, with each scene's mu, k_r, k_d [1/s]
    and t_max [s] as non-index coordinates along it."""
    table = scene_table(s)
    return Axis("scene", np.array(SCENES), "", "physical scene (docs/outcome-studies.md#scenes): " + "; ".join(
        f"{label} = {title}" for label, title in SCENE_TITLES.items()), aux={
        "mu": (table["mu"], "1", "Coulomb friction coefficient of the scene (inf: rolling only)"),
        "k_r": (table["k_r"], "s-1", "rolling-resistance rate k_r of the scene, paper (83)"),
        "k_d": (table["k_d"], "s-1", "drilling-resistance rate k_d of the scene, paper (83)"),
        "t_max": (table["t_max"], "s", "end of the run for states still on the rim"),
    })


def scene_index(label) -> int:
    """Position of a scene label in :data:`SCENES` (the row of :func:`scene_table`)."""
    return SCENES.index(str(label))


def _axes(s: dict) -> list[Axis]:
    scene = scene_axis(s)
    beta = Axis("beta", np.linspace(s["beta_min"], s["beta_max"], int(s["n_beta"])), "rad",
                "initial height angle of the contact point on the rim's cross-section")
    w = float(s["omega1_max"])
    omega1 = Axis("omega1", np.linspace(-w, w, int(s["n_omega1"])), "s-1", "initial transversal angular velocity")
    return [scene, beta, omega1]


def _compute(coords, p: solver.Params, s: dict) -> dict:
    scene, beta, omega1 = coords
    k = scene_index(scene.flat[0])  # chunks hold one scene (chunks={"scene": 1})
    table = scene_table(s)
    params = p.replace(mu=table["mu"][k], k_r=table["k_r"][k], k_d=table["k_d"][k])
    states = np.stack([beta, omega1, np.full_like(beta, s["omega2"]), np.full_like(beta, s["omega3"])], axis=-1)
    return solver.simulate(states, params, t_max=table["t_max"][k], rtol=s["rtol"], atol=s["atol"],
                           method=s["method"], workers=1)


BOUNDARY_ATTRS = {
    "units": "1",
    "long_name": "type of the boundary of periodic rolling at this initial state (paper Sect. 5.1)",
    "flag_values": np.array(boundaries.BOUNDARY_FLAG_VALUES, dtype="int8"),
    "flag_meanings": boundaries.BOUNDARY_FLAG_MEANINGS,
    "comment": "solver.boundaries.classify on each scene's (beta, omega1) grid with its default thresholds "
               + ", ".join(f"{k}={v:g}" for k, v in boundaries.DEFAULTS.items())
               + "; slipping scenes are compared with the rolling-only scene (slipping_induced)",
}


def _derive(ds) -> dict:
    """``boundary_type`` of every scene, from the whole (beta, omega1) grid of each."""
    p = params_of(ds)
    dims = ("scene", "beta", "omega1")
    get = lambda name: ds[name].transpose(*dims).values
    outcome, f2, hp, t_end = get("outcome"), get("f2_min"), get("half_period"), get("t_end")
    mu = ds["mu"].values
    conservative = (ds["k_r"].values == 0) & (ds["k_d"].values == 0)
    rolling = [k for k in range(mu.size) if np.isinf(mu[k]) and conservative[k]]
    labels = np.empty(outcome.shape, dtype=np.int8)
    for k in range(mu.size):
        ref = outcome[rolling[0]] if rolling and np.isfinite(mu[k]) else None
        labels[k] = boundaries.classify(outcome[k], f2[k], hp[k], t_end[k], p.m * p.g, rolling_outcome=ref)
    return {"boundary_type": (dims, labels, BOUNDARY_ATTRS)}


BOUNDARY_MARKERS = {  # how the plot draws each boundary type
    boundaries.DEADLOCK: dict(marker=".", ls="", ms=3.5, color="k", label="deadlock boundary (F2_min -> 0)"),
    boundaries.SEPARATRIX: dict(marker="x", ls="", ms=3.5, mew=0.9, color="white",
                                label="separatrix boundary (half period -> inf)"),
    boundaries.SLIPPING_INDUCED: dict(marker="+", ls="", ms=4.0, mew=0.9, color="#7a0177",
                                      label="slipping-induced boundary"),
}


def _draw_boundaries(ax, sel, w1, beta) -> None:
    if "boundary_type" not in sel:
        return
    lab = sel["boundary_type"].transpose("beta", "omega1").values
    W, B = np.meshgrid(w1, beta)
    for code, style in BOUNDARY_MARKERS.items():
        m = lab == code
        if m.any():
            ax.plot(W[m], B[m], zorder=4, **{k: v for k, v in style.items() if k != "label"})


def steady_beta0(omega2: float, omega3: float, p: solver.Params, lo: float, hi: float) -> float | None:
    """beta0 in [lo, hi] [rad] of the steady motion (48) with these omega20, omega30; None if none."""
    f = lambda b: steady.omega20(b, omega3, p) - omega2
    grid = np.linspace(lo, min(hi, np.pi / 2 - 1e-6), 400)
    vals = f(grid)
    sign = np.nonzero(np.sign(vals[:-1]) != np.sign(vals[1:]))[0]
    return float(brentq(f, grid[sign[0]], grid[sign[0] + 1])) if sign.size else None


def _plot(ds):
    fig = Figure(figsize=(11.0, 9.0), layout="constrained")
    axes = fig.subplots(2, 2, sharex=True, sharey=True)
    w1 = ds["omega1"].values
    beta = ds["beta"].values
    cmap = ListedColormap(OUTCOME_COLOURS)
    norm = BoundaryNorm(np.arange(-0.5, 4.5), cmap.N)
    p = params_of(ds)
    omega2, omega3 = float(setting_of(ds, "omega2")), float(setting_of(ds, "omega3"))
    b0 = steady_beta0(omega2, omega3, p, beta.min(), beta.max())
    conservative_periodic = None
    for k, ax in enumerate(axes.flat):
        sel = ds.isel(scene=k)
        out = sel["outcome"].transpose("beta", "omega1").values
        ax.pcolormesh(w1, beta, out, cmap=cmap, norm=norm, shading="nearest", rasterized=True)
        _draw_boundaries(ax, sel, w1, beta)
        mu, k_r, k_d = (float(sel[c]) for c in ("mu", "k_r", "k_d"))
        if k_r == 0 and k_d == 0:
            conservative_periodic = out == outcomes.PERIODIC_ROLLING
        else:
            t_end = sel["t_end"].transpose("beta", "omega1").values
            levels = [lv for lv in (5.0, 10.0, 20.0, 40.0) if lv < float(sel["t_max"])]
            cs = ax.contour(w1, beta, t_end, levels=levels, colors="k", linewidths=0.7, linestyles="-")
            ax.clabel(cs, fmt="%g s", fontsize=7)
            if conservative_periodic is not None and conservative_periodic.any():
                ax.contour(w1, beta, conservative_periodic.astype(float), levels=[0.5], colors="k",
                           linewidths=0.9, linestyles=":")
        if b0 is not None:
            ax.plot([0.0], [b0], marker="*", ms=13, mfc="yellow", mec="k", zorder=5)
        mu_txt = r"$\mu=\infty$" if np.isinf(mu) else rf"$\mu={mu:g}$"
        extra = (rf", $k_d={k_d:g}$ 1/s" if k_d else "") + (rf", $k_r={k_r:g}$ 1/s" if k_r else "")
        label = str(sel["scene"].values)
        ax.set_title(f"{SCENE_TITLES.get(label, label)} ({mu_txt}{extra})", fontsize=10)
    for ax in axes[1]:
        ax.set_xlabel(r"initial transversal angular velocity $\omega_1$ [1/s]")
    for ax in axes[:, 0]:
        ax.set_ylabel(r"initial height angle $\beta$ [rad]")
    handles = [Patch(color=c, label=lbl) for c, lbl in zip(OUTCOME_COLOURS, (
        "falls in (score)", "falls out", "periodic rolling", "on the rim at t_max"))]
    handles.append(Line2D([], [], marker="*", ls="", ms=12, mfc="yellow", mec="k", label="steady motion (48)"))
    if "boundary_type" in ds:
        for style in BOUNDARY_MARKERS.values():
            st = dict(style, ms=7)
            if st["color"] == "white":
                st["mec"] = st["color"] = "0.4"  # white crosses are invisible on the legend's background
            handles.append(Line2D([], [], **st))
    fig.legend(handles=handles, loc="outside lower center", ncol=4, fontsize=9, frameon=False)
    fig.suptitle(rf"{ds.attrs['title']}: $\omega_2={omega2:g}$ 1/s, $\omega_3={omega3:g}$ 1/s"
                 "\nlines in dissipative panels: time on the rim; dotted: former periodic region", fontsize=11)
    return fig


for _name, _omega2, _fig in (("fig11", 35.0, 11), ("fig12", 65.0, 12), ("fig13", 105.0, 13)):
    register(Study(
        name=_name,
        title=f"Outcome of a ball on the rim (paper Fig. {_fig})",
        settings={**SETTINGS, "omega2": _omega2},
        quick=QUICK,
        axes=_axes,
        variables=VARIABLES,
        compute=_compute,
        plot=_plot,
        chunks={"scene": 1, "beta": 24},
        derive=_derive,
    ))
