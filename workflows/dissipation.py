"""Sect. 5.3's open question: how the fate of the former periodic islands depends on the dissipation model.

``dissipation-models``: the periodic islands of the Figs. 11-13 sections (the periodic cells of the
conservative rolling-only map and of the conservative slipping map, mu = mu_slip) are run again
under each dissipation model of :data:`MODELS` at a sweep of its strength, with slipping (mu =
mu_slip, as the dissipative panels of Figs. 11-13 and Sect. 5.3 run them; ``--set mu_slip=inf``
runs everything rolling only), and each island state's fate is stored: fall in, fall out, still on
the rim at t_max (and the time it stayed).

**Strength.** Every model is scaled by one number, ``k_equivalent`` [1/s]: the rate of the paper's
linear moment (83) that removes energy at the same mean rate on the steady motions (48) of the
paper's three sections (omega2 = 35, 65, 105 1/s, omega3 = 10 1/s). So k_equivalent = 0.02 1/s
is "the paper's strength" for every model, and the models differ only in how the loss is spread
over the states (see :func:`equivalence`; the factors are stored in the file).

Every run of one island goes through one compiled kernel per phase set holding all three load terms
(Coulomb rolling, Coulomb drilling, air drag; a term at zero strength adds exact zeros, so each
model's numbers are those of its own scene kernel, bit for bit: tests/solver/physics/test_dissipation_terms.py).
"""

from __future__ import annotations

import numpy as np
from matplotlib.figure import Figure

from rimroll import solver
from rimroll.solver.engine import outcomes
from rimroll.solver.physics import air, loads, resistance, rolling, switching
from rimroll.solver.physics.params import DISSIPATION_KEYS, QUANTITIES
from rimroll.study import plotting as P
from rimroll.study.dataset import setting_of
from rimroll.study.outcome_sections import BETA_COMMENT, OMEGA1_COMMENT, engine_options, steady_beta0
from rimroll.study.registry import Axis, ReferenceSpec, Study, Var, register

LOAD_TERMS = ("coulomb_rolling", "coulomb_drilling", "air_drag")
"""The load terms of the scene table every run of this study compiles (each at its model's strength)."""
MODELS = {  # name: (reader-facing text, {parameter: what it scales with})
    "linear_rolling": ("linear rolling resistance (83), k_r", {"k_r": "k"}),
    "linear_drilling": ("linear drilling resistance (83), k_d", {"k_d": "k"}),
    "linear_both": ("linear (83), k_r = k_d", {"k_r": "k", "k_d": "k"}),
    "coulomb_rolling": ("Coulomb rolling resistance, c_r", {"c_r": "c_r"}),
    "coulomb_drilling": ("Coulomb drilling resistance, c_d", {"c_d": "c_d"}),
    "coulomb_both": ("Coulomb rolling + drilling", {"c_r": "c_r", "c_d": "c_d"}),
    "air": ("air drag, rho_air", {"rho_air": "rho_air"}),
    "coulomb_both_air": ("Coulomb rolling + drilling + air drag", {"c_r": "c_r", "c_d": "c_d", "rho_air": "rho_air"}),
}
"""The dissipation models: each sets its parameters to ``k_equivalent`` times the factor of
:func:`equivalence` named (``k``: 1, the linear rates themselves)."""
ISLANDS = ("rolling_only", "slipping")
PAPER_OMEGA2 = (35.0, 65.0, 105.0)
PAPER_OMEGA3 = 10.0
"""omega2, omega3 [1/s] of the paper's sections: their steady motions fix the equivalence of the models."""
OUTSIDE, FAILED = -1, -2
FATE_VALUES = (FAILED, OUTSIDE, *outcomes.OUTCOME_FLAG_VALUES)
FATE_MEANINGS = "failed outside_island " + outcomes.OUTCOME_FLAG_MEANINGS


def reference_states(p: solver.Params, omega3: float = PAPER_OMEGA3) -> np.ndarray:
    """The steady motions (48) of the paper's three sections, (beta0, 0, omega2, omega3) [rad, 1/s],
    beta0 in [0.8, 1.8] rad (the sections' range)."""
    rows = []
    for omega2 in PAPER_OMEGA2:
        b0 = steady_beta0(omega2, omega3, p, 0.8, 1.8)
        if b0 is None:
            raise ValueError(f"no steady motion (48) with omega2 = {omega2:g}, omega3 = {omega3:g} 1/s and beta0 in "
                             "[0.8, 1.8] rad: the equivalence of the dissipation models is defined on them")
        rows.append((b0, 0.0, omega2, omega3))
    return np.array(rows)


def _mean_power(load_fn, p: solver.Params, states) -> float:
    pa = p.as_array()
    out = []
    for b, w1, w2, w3 in states:
        v1, v3 = -p.r * w3, p.r * w1  # the centre's velocity of a rolling ball (19), (20) [m/s]
        out.append(loads.power(load_fn(b, w1, w2, w3, 0.0, 0.0, pa), w1, w2, w3, v1, 0.0, v3))
    return float(np.mean(out))


def equivalence(p: solver.Params) -> dict[str, float]:
    """The parameter of each nonlinear model per unit of k_equivalent: c_r, c_d [m s] and rho_air
    [kg m-3 s] that remove energy at the same mean rate [W] over :func:`reference_states` as the
    linear moment (83) at rate 1 1/s in the same components (rolling: omega1, omega3; drilling:
    omega2; air: all three, k_r = k_d = 1 1/s)."""
    states = reference_states(p)
    pa_r = p.replace(k_r=1.0).as_array()
    pa_d = p.replace(k_d=1.0).as_array()
    linear_r = float(np.mean([rolling.dissipated_power(w1, w2, w3, pa_r) for _, w1, w2, w3 in states]))
    linear_d = float(np.mean([rolling.dissipated_power(w1, w2, w3, pa_d) for _, w1, w2, w3 in states]))
    arm = 1e-3  # [m] the powers are linear in c_r, c_d (which must stay below r)
    return {"c_r": linear_r * arm / _mean_power(resistance.coulomb_rolling, p.replace(c_r=arm), states),
            "c_d": linear_d * arm / _mean_power(resistance.coulomb_drilling, p.replace(c_d=arm), states),
            "rho_air": (linear_r + linear_d) / _mean_power(air.air_drag, p.replace(rho_air=1.0), states)}


def model_params(model: str, k: float, p: solver.Params, factors: dict) -> solver.Params:
    """``p`` with the model's parameters at strength k [1/s] (:data:`MODELS`), every other term off."""
    if model not in MODELS:
        raise ValueError(f"unknown dissipation model {model!r}; known: {', '.join(MODELS)}")
    values = dict.fromkeys(DISSIPATION_KEYS, 0.0)
    for name, scale in MODELS[model][1].items():
        values[name] = k * (1.0 if scale == "k" else factors[scale])
    return p.replace(**values)


def check_models(s: dict, p: solver.Params) -> None:
    """ValueError unless every model's parameters at every ``k_equivalent`` of the run are valid (a Coulomb
    arm c_r, c_d [m] must stay below the ball's radius r): names the models that fail and the largest
    strength [1/s] every model allows for this ball."""
    k_max = float(np.max(np.atleast_1d(s["k_equivalent"])))
    if not k_max > 0:
        return
    factors = equivalence(p.replace(mu=float(np.max(np.atleast_1d(s["mu_slip"])))))
    failing = []
    for name in MODELS:
        try:
            model_params(name, k_max, p, factors)
        except ValueError as exc:
            failing.append((name, str(exc)))
    if failing:
        bound = p.r / max(factors["c_r"], factors["c_d"])
        names = ", ".join(name for name, _ in failing)
        raise ValueError(f"k_equivalent={k_max:g} 1/s is beyond what the models allow for this ball: {names} "
                         f"({failing[0][1]}); every model needs k_equivalent < {bound:.4g} 1/s here "
                         f"(r = {p.r:g} m)")


def _axes(s: dict) -> list[Axis]:
    if s["n_beta"] < 2 or s["n_omega1"] < 2:
        raise ValueError(f"n_beta and n_omega1 must be >= 2; got {s['n_beta']}, {s['n_omega1']}")
    w = float(s["omega1_max"])
    return [
        Axis("island", np.array(ISLANDS), "", "periodic island: of the conservative rolling-only map (mu = inf) or "
             "of the conservative slipping map (mu = mu_slip)"),
        Axis("model", np.array(list(MODELS)), "", "dissipation model: " + "; ".join(
            f"{name} = {text}" for name, (text, _) in MODELS.items())),
        Axis("beta", np.linspace(s["beta_min"], s["beta_max"], int(s["n_beta"])), "rad", "initial height angle",
             comment=BETA_COMMENT),
        Axis("omega1", np.linspace(-w, w, int(s["n_omega1"])), "s-1", "initial omega1", comment=OMEGA1_COMMENT),
    ]


def _compute(coords, p: solver.Params, s: dict) -> dict:
    """One island (all models) of one section at one strength: the conservative map (rolling only, or
    slipping with mu_slip) finds the island (periodic cells and the steady motion), then every model
    runs the island's states with slipping (mu = mu_slip; k_equivalent = 0: the conservative run)."""
    island, model, beta, omega1 = coords
    label = str(island.flat[0])
    p = p.replace(mu=s["mu_slip"])  # the models run with slipping, as the dissipative panels of Figs. 11-13
    b, w = beta[0, 0], omega1[0, 0]
    states = np.stack([b, w, np.full_like(b, s["omega2"]), np.full_like(b, s["omega3"])], axis=-1)
    options = dict(rtol=s["rtol"], atol=s["atol"], method=s["method"], workers=1, **engine_options(s))
    # the conservative map through the kernel of the models (its terms at zero strength give the scene
    # without them bit for bit): one kernel per phase set for the whole study
    quiet = p.replace(**dict.fromkeys(DISSIPATION_KEYS, 0.0))
    conservative = solver.simulate(states, quiet.replace(mu=np.inf) if label == "rolling_only" else quiet,
                                   t_max=s["t_max"], terms=LOAD_TERMS, **options)
    inside = np.isin(conservative["outcome"], (outcomes.PERIODIC_ROLLING, outcomes.STEADY_MOTION))
    fate = np.full(model.shape, OUTSIDE, dtype=np.int8)
    t_on_rim = np.full(model.shape, np.nan)
    k = float(s["k_equivalent"])
    factors = equivalence(p)
    for m, name in enumerate(model[0, :, 0, 0]):
        if k == 0.0:  # no dissipation: the conservative run itself
            res = {key: conservative[key][inside] for key in ("outcome", "status", "t_end")}
        else:
            res = solver.simulate(states[inside], model_params(str(name), k, p, factors), t_max=s["t_max_dissipative"],
                                  terms=LOAD_TERMS, **options)
        ok = res["status"] == outcomes.OK
        fate[0, m][inside] = np.where(ok, res["outcome"], FAILED)
        t_on_rim[0, m][inside] = np.where(ok, res["t_end"], np.nan)  # a failed run has no time on the rim
    return {"fate": fate, "t_on_rim": t_on_rim}


FRACTIONS = (("fall_in", outcomes.FALL_IN), ("fall_out", outcomes.FALL_OUT),
             ("on_rim", outcomes.ON_RIM_AT_T_MAX), ("periodic", outcomes.PERIODIC_ROLLING), ("failed", FAILED))


def _ball(ds) -> solver.Params:
    """The ball, rim and air of a results file (its recorded physical parameters; the models set the
    dissipation ones)."""
    keys = ("r", "R", "a", "m", "j", "g", "C_D")
    return solver.Params(**{k: float(setting_of(ds, k)) for k in keys if f"param_{k}" in ds.attrs})


def _derive(ds) -> dict:
    """Per (omega2, k_equivalent, island, model): the island's size and the fraction of each fate;
    per (k_equivalent, model): the parameters each model ran at."""
    fate = ds["fate"]
    inside = fate != OUTSIDE
    cells = inside.sum(("beta", "omega1"))
    dims = cells.dims
    out = {"island_cells": (dims, cells.values.astype(np.int32), {
        "units": "1", "long_name": "initial states (cells) of the periodic island"})}
    for name, code in FRACTIONS:
        frac = (fate == code).sum(("beta", "omega1")) / cells.where(cells > 0)
        out[f"fraction_{name}"] = (dims, frac.values, {
            "units": "1", "long_name": f"fraction of the island's states whose fate is {name.replace('_', ' ')}"})
    out["mean_t_on_rim"] = (dims, ds["t_on_rim"].mean(("beta", "omega1")).values, {
        "units": "s", "long_name": "mean time on the rim of the island's states (until the fall or "
        "t_max_dissipative; failed runs left out)"})
    p = _ball(ds)
    factors = equivalence(p)
    k_values = ds["k_equivalent"].values if "k_equivalent" in ds.dims else np.array([setting_of(ds, "k_equivalent")])
    pdims = (("k_equivalent",) if "k_equivalent" in ds.dims else ()) + ("model",)
    for key in DISSIPATION_KEYS:
        table = np.array([[getattr(model_params(str(m), float(k), p, factors), key) for m in ds["model"].values]
                          for k in k_values])
        units = QUANTITIES[key].units
        out[f"model_{key}"] = (pdims, table if "k_equivalent" in ds.dims else table[0], {
            "units": units, "long_name": f"{key} of each model at each strength ({units})",
            "comment": "k_equivalent times the model's equivalence factor (workflows.dissipation.equivalence)"})
    return out


DERIVED_DOCS = (
    ("island_cells", "1", "initial states of the periodic island (per omega2, k_equivalent, island, model)"),
    (tuple(f"fraction_{name}" for name, _ in FRACTIONS), "1", "fraction of the island's states that fall in, fall "
     "out, are still on the rim at t_max_dissipative, roll periodically (k_equivalent = 0 only), failed (an "
     "integration status other than ok)"),
    ("mean_t_on_rim", "s", "mean time on the rim of the island's states"),
    (("model_k_r", "model_k_d", "model_c_r", "model_c_d", "model_rho_air"), "s-1 / m / kg m-3",
     "the parameters each model ran at, per (k_equivalent, model)"),
)

def _table(ds, name: str, island, omega2) -> np.ndarray:
    """A derived variable of one (island, omega2) as a (model, k_equivalent) table."""
    da = ds[name].sel(island=island)
    if "omega2" in da.dims:
        da = da.sel(omega2=omega2)
    if "k_equivalent" not in da.dims:
        da = da.expand_dims("k_equivalent")
    return da.transpose("model", "k_equivalent").values


def _plot(ds):
    """Top: per (island, omega2), a table of models x strengths coloured by the fraction of the
    island that falls in (blue) rather than out (orange), each cell labelled with the percentages in /
    out; below: the fate over the largest island at the paper's strength, per model."""
    from matplotlib.colors import LinearSegmentedColormap

    omega2 = np.atleast_1d(ds["omega2"].values) if "omega2" in ds.dims else np.array([setting_of(ds, "omega2")])
    k_values = np.atleast_1d(ds["k_equivalent"].values if "k_equivalent" in ds.dims
                             else [float(setting_of(ds, "k_equivalent"))])
    ncol = max(len(omega2), 4)
    fig = Figure(figsize=(4.4 * ncol, 15.0), layout="constrained")
    grid = fig.add_gridspec(4, ncol)
    out_in = LinearSegmentedColormap.from_list("out_in", [P.OUTCOME_PALETTE.colour(outcomes.FALL_OUT), "#f7f7f7",
                                                          P.OUTCOME_PALETTE.colour(outcomes.FALL_IN)])
    image = None
    for row, island in enumerate(ds["island"].values):
        for col, w2 in enumerate(omega2):
            ax = fig.add_subplot(grid[row, col])
            fin, fout = (_table(ds, f"fraction_{k}", island, w2) for k in ("fall_in", "fall_out"))
            image = ax.imshow(fin - fout, cmap=out_in, vmin=-1, vmax=1, aspect="auto")
            periodic = _table(ds, "fraction_periodic", island, w2)
            failed = _table(ds, "fraction_failed", island, w2) if "fraction_failed" in ds else np.zeros_like(fin)
            for (m, k), v in np.ndenumerate(fin):
                text = ("" if np.isnan(v) else "periodic" if periodic[m, k] == 1
                        else f"{100 * v:.0f}/{100 * fout[m, k]:.0f}")
                if failed[m, k] > 0:
                    text += f"\n{100 * failed[m, k]:.0f}% failed"
                ax.text(k, m, text, ha="center", va="center", fontsize=6.5)
            cells = int(np.nanmax(_table(ds, "island_cells", island, w2)))
            ax.set_title(rf"{str(island).replace('_', ' ')} island, $\omega_2$ = {w2:g} 1/s: {cells} states",
                         fontsize=9)
            ax.set_xticks(range(len(k_values)), [f"{k:g}" for k in k_values], fontsize=7)
            ax.set_yticks(range(ds.sizes["model"]), [str(m) for m in ds["model"].values] if col == 0 else [],
                          fontsize=7)
            ax.set_xlabel(r"strength $k_{eq}$ [1/s] (the paper's: 0.02)", fontsize=8)
    if image is not None:  # the colour scale in the free column of the top rows, with how to read a cell
        holder = fig.add_subplot(grid[0:2, ncol - 1])
        holder.axis("off")
        cbar = fig.colorbar(image, cax=holder.inset_axes([0.0, 0.3, 0.07, 0.65]))
        cbar.set_label("fraction in - fraction out", fontsize=8)
        holder.text(0.0, 0.22, "a cell: % of the island that falls in / falls out;\nthe rest is still on the rim at "
                    f"t_max = {float(setting_of(ds, 't_max_dissipative')):g} s\n(k_eq = 0: the conservative island, "
                    "periodic;\nfailed: runs whose integration did not finish ok,\nblank in the maps)", fontsize=8,
                    va="top", transform=holder.transAxes)
    _maps(fig, grid, ds)
    fig.suptitle("Sect. 5.3: the fate of the periodic islands of Figs. 11-13 under each dissipation model, at "
                 r"equal mean power ($k_{eq}$: the rate of (83) removing as much energy on the steady motions)",
                 fontsize=11)
    return fig


def _maps(fig, grid, ds) -> None:
    """The fate over one island at the strength nearest 0.02 1/s, one map per model, zoomed to the
    island, in rows 3-4 of ``grid``: the island (over omega2 and island) where the models disagree
    most (the spread of the fraction in over the models, plus how mixed in and out are within a model)."""
    one = ds
    if "k_equivalent" in ds.dims:
        one = one.sel(k_equivalent=0.02, method="nearest")
    fin, fout = one["fraction_fall_in"].fillna(0.0), one["fraction_fall_out"].fillna(0.0)
    score = fin.max("model") - fin.min("model") + (4.0 * fin * fout).mean("model")
    score = score.where(one["island_cells"].isel(model=0) > 0, -1.0)
    flat = int(np.argmax(score.values))
    pick = dict(zip(score.dims, np.unravel_index(flat, score.shape)))
    one = one.isel(**pick)
    fate = one["fate"].transpose("model", "beta", "omega1").values
    rows, cols = np.nonzero(fate[0] != OUTSIDE)
    if not rows.size:
        return
    pad = 2  # cells around the island: a one-row island still has an extent to draw
    b_sl = slice(max(rows.min() - pad, 0), rows.max() + 1 + pad)
    w_sl = slice(max(cols.min() - pad, 0), cols.max() + 1 + pad)
    beta, w1 = one["beta"].values[b_sl], one["omega1"].values[w_sl]
    k_eq = float(setting_of(one, "k_equivalent"))
    for m, model in enumerate(one["model"].values):
        ax = fig.add_subplot(grid[2 + m // 4, m % 4])
        P.outcome_map(ax, w1, beta, np.ma.masked_less(fate[m, b_sl, w_sl], 0))
        ax.set_title(f"{MODELS[str(model)][0]}\n{str(one['island'].values)} island, omega2 = "
                     f"{float(setting_of(one, 'omega2')):g} 1/s, k_eq = {k_eq:g} 1/s", fontsize=8)
        ax.tick_params(labelsize=7)
        ax.set_xlabel(r"initial $\omega_1$ [1/s]", fontsize=7)
        ax.set_ylabel(r"initial $\beta$ [rad]", fontsize=7)
    fig.legend(handles=P.OUTCOME_PALETTE.handles(np.unique(fate[fate >= 0])), loc="outside lower center", ncol=5,
               fontsize=8, frameon=False)


SETTINGS = {
    "omega2": PAPER_OMEGA2,  # [1/s] the three sections
    "k_equivalent": (0.0, 0.005, 0.01, 0.02, 0.04, 0.08),  # [1/s]
    "omega3": 10.0,
    "beta_min": 0.8, "beta_max": 1.8, "n_beta": 240,  # the grids of Figs. 11-13
    "omega1_max": 20.0, "n_omega1": 360,
    "mu_slip": 1.0,
    "t_max": 20.0,  # [s] the conservative maps that find the islands
    "t_max_dissipative": 60.0,  # [s]
    "rtol": 1e-8, "atol": 1e-10, "method": "dp5",
    "delta": switching.DELTA, "slip_method": "rodas4",
}

register(Study(
    name="dissipation-models",
    title="Sect. 5.3's open question: the fate of the periodic islands of Figs. 11-13 under each dissipation model",
    settings=SETTINGS,
    quick={"k_equivalent": (0.0, 0.02, 0.06), "n_beta": 24, "n_omega1": 36},
    sweepable=("omega2", "k_equivalent"),
    axes=_axes,
    check=check_models,
    variables=[
        Var("fate", "1", "fate of the island's initial state under the model (outside_island elsewhere)", dtype="int8",
            flag_values=FATE_VALUES, flag_meanings=FATE_MEANINGS),
        Var("t_on_rim", "s", "time on the rim of the island's initial state (until the fall or t_max_dissipative)"),
    ],
    compute=_compute,
    plot=_plot,
    chunks={"island": 1},
    derive=_derive,
    derived_docs=DERIVED_DOCS,
    ignores={k: "each model sets its own dissipation parameters; change k_equivalent"
             for k in ("k_r", "k_d", "c_r", "c_d", "rho_air", "mu")},
    cost=1e-5, compiles=True,  # seconds per grid point on one core (only island states run), warm
    # a regression reference at the study's own settings: the fate of an island state near the edge
    # between in and out may change with the tolerance, which is the study's setting to choose
    reference=ReferenceSpec({"beta": 24, "omega1": 36}, sets={"omega2": 65, "k_equivalent": (0, 0.02)}),
))
