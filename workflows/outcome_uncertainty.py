"""Predictability of a shot: how sharp the outcome boundaries are, and what noise does to a throw.

- ``predictability``: on each Fig. 11-13 section (``omega2`` swept: 35, 65, 105 1/s) and in each
  scene of the outcome studies, the outcome grid, the entropy of each 5 x 5 box, and which
  points are eps-uncertain (the outcome changes when beta or omega1 moves by +-eps grid
  steps); derived from the whole grid: the basin entropies S_b, S_bb, the uncertain fraction
  f(eps) over eps = 2^-n_fine ... 2^n_coarse grid steps and the uncertainty exponent alpha
  (fit of log f against log eps) with its error and the boundary dimension D = 2 - alpha.
  Whole eps are read from the grid; eps below one step are simulated on a stratified sample
  (``solver.predictability.section_uncertainty``), or, with ``eps_pairs = refined``, read for every
  grid point from an adaptive map of the section 2**n_fine times finer whose coarse lattice is the
  grid (``solver.analysis.adaptive_map``; ``solver.predictability.refined_uncertain``).
- ``make-probability``: the probability of each outcome of a throw whose arriving state is
  normal around each nominal state of the (beta, omega1) section, with spread
  sigma * (sigma_beta, sigma_omega1, sigma_omega2, sigma_omega3), Wilson intervals and the
  deterministic outcome beside it. Sweepable over sigma, mu, k_r, k_d, omega2, omega3.

Outcome codes and names come from ``solver.OUTCOME_MEANINGS`` and colours from the one outcome
palette of every figure (``study.plotting.OUTCOME_PALETTE``): a new outcome gets its own
probability variable and colour without an edit here.
"""

from __future__ import annotations

import numpy as np
from matplotlib.figure import Figure
from matplotlib.patches import Rectangle
from matplotlib.ticker import FixedLocator, FuncFormatter, NullLocator

from rimroll import solver
from rimroll.solver.analysis import adaptive_map
from rimroll.solver.analysis import exponent_bootstrap as boot
from rimroll.solver.analysis import predictability as pred
from rimroll.solver.engine import outcomes
from rimroll.solver.physics.params import TERM_KEYS
from rimroll.study import cubeplots as C
from rimroll.study import outcome_sections as sections
from rimroll.study import plotting as P
from rimroll.study.dataset import setting_of
from rimroll.study.registry import Axis, ReferenceSpec, Study, Var, output_var, register

# ================================================================ outcome names and colours
OUTCOME_NAMES = {code: meaning.split(":")[0] for code, meaning in solver.OUTCOME_MEANINGS.items()}
PALETTE = P.OUTCOME_PALETTE  # the one outcome palette of every outcome figure


def _outcome_map(ax, w1, beta, codes):
    """Draw an outcome grid (beta x omega1) in the outcome palette; returns legend handles."""
    cmap, norm = PALETTE.cmap_norm()
    ax.pcolormesh(w1, beta, codes, cmap=cmap, norm=norm, shading="nearest", rasterized=True)
    return PALETTE.handles(np.unique(codes))


def _outcome_var() -> Var:
    return output_var("outcome", long_name="deterministic outcome of the nominal state")


def _section_states(beta, omega1, s):
    return np.stack([beta, omega1, np.full_like(beta, s["omega2"]), np.full_like(beta, s["omega3"])], axis=-1)


# ================================================================ predictability
PRED_SETTINGS = {
    **{k: v for k, v in sections.SETTINGS.items()},
    "method": "dp5",  # its reference slices are a regression of dp5's uncertain pairs (auto changes them)
    "omega2": (35.0, 65.0, 105.0),  # [1/s] the sections of Figs. 11, 12, 13
    "box": 5,  # points per side of an entropy box
    "n_fine": 3,  # eps = 1/2, 1/4, 1/8 grid steps: simulated
    "n_coarse": 2,  # eps = 1, 2, 4 grid steps: read from the grid
    "n_sample": 2000,  # points drawn from the grid's certain part for the eps < 1 test
    "eps_pairs": "sampled",  # eps < 1: simulated on a stratified sample, or "refined": read from an adaptive map
    "seed": 0,
}
PRED_QUICK = {**sections.QUICK, "n_sample": 200, "n_coarse": 1, "box": 4}
"""The quick grid, 24 x 36, holds whole boxes of 4 x 4 (5 x 5 left strips without a box)."""


MAX_REFINED = 1 << 25
"""Points of the refined grid of ``eps_pairs = refined`` (the default grid refined 8 times: 5.5 million)."""


def eps_values(n_fine: int, n_coarse: int) -> np.ndarray:
    """eps [grid steps] of the predictability study: 2^-n_fine ... 2^n_coarse."""
    return 2.0 ** np.arange(-int(n_fine), int(n_coarse) + 1)


def _pred_axes(s):
    if s["n_fine"] < 0 or s["n_coarse"] < 0 or s["n_fine"] + s["n_coarse"] < 2:
        raise ValueError(f"n_fine, n_coarse must be >= 0 with at least 3 eps in all; got {s['n_fine']}, "
                         f"{s['n_coarse']}")
    if s["box"] < 2 or s["box"] > min(s["n_beta"], s["n_omega1"]):
        raise ValueError(f"box must be >= 2 and fit the grid ({s['n_beta']} x {s['n_omega1']}); got {s['box']}")
    if s["n_sample"] < 0:
        raise ValueError(f"n_sample must be >= 0; got {s['n_sample']}")
    if 2 ** int(s["n_coarse"]) >= min(s["n_beta"], s["n_omega1"]) - 1:
        raise ValueError(f"n_coarse = {s['n_coarse']}: the largest eps, 2**n_coarse = {2 ** int(s['n_coarse'])} grid "
                         f"steps, must be shorter than the grid ({s['n_beta']} x {s['n_omega1']} points)")
    if s["n_fine"] + s["n_coarse"] + 1 > 31:
        raise ValueError("at most 31 eps (the uncertain flags are bits of an int32)")
    k = 2 ** int(s["n_fine"])
    fine = ((int(s["n_beta"]) - 1) * k + 1) * ((int(s["n_omega1"]) - 1) * k + 1)
    if s["eps_pairs"] == "refined" and fine > MAX_REFINED:
        raise ValueError(f"eps_pairs=refined: the grid refined 2**n_fine = {k} times would have {fine:,} points, "
                         f"more than {MAX_REFINED:,} (about 200 bytes each while it is built); lower n_fine or "
                         "n_beta, n_omega1")
    return sections.section_axes(s)


def _scene(coords, p, s):
    """Params and t_max of the chunk's scene (chunks hold one scene; ``scene`` holds labels)."""
    return sections.scene_params(p, s, coords[0].flat[0])


def _refined(beta, omega1, params, s, sim, eps):
    """``eps_pairs = refined``: the section on its grid refined 2**n_fine times, as an adaptive map whose
    coarse lattice is the grid itself (``solver.analysis.adaptive_map``), and every grid point's eps-uncertain flags
    read from it (``predictability.refined_uncertain``). Returns (outcome, status, uncertain, eps_runs) on
    the grid; ``eps_runs``: fine states simulated in the k x k block at each grid point (itself excluded)."""
    k = 2 ** int(s["n_fine"])
    fb, fw = pred.refined_axis(beta[:, 0], k), pred.refined_axis(omega1[0], k)
    keep = set(adaptive_map.NEEDED) | {"status"}

    def cells(i, j):
        x = np.stack([fb[i], fw[j], np.full(i.size, s["omega2"]), np.full(i.size, s["omega3"])], axis=-1)
        return {name: v for name, v in solver.simulate(x, params, **sim).items() if name in keep}
    falls = (outcomes.FALL_IN, outcomes.FALL_OUT, outcomes.ON_RIM_AT_T_MAX)
    fields, level = adaptive_map.adaptive_map(cells, (fb.size, fw.size), k, weight=params.m * params.g,
                                          periodic_code=outcomes.PERIODIC_ROLLING, falls=falls,
                                          inner_neighbours=False, filled=("outcome",))
    fine = fields["outcome"]
    simulated = np.pad(level != adaptive_map.FILLED, ((0, k - 1), (0, k - 1)))  # the last row/column: blocks of one
    n_b, n_w = beta.shape
    runs = simulated.reshape(n_b, k, n_w, k).sum(axis=(1, 3)) - 1
    return fine[::k, ::k], fields["status"][::k, ::k], pred.refined_uncertain(fine, k, eps), runs.astype(np.int32)


def _pred_compute(coords, p, s):
    _, beta, omega1 = coords
    params, t_max = _scene(coords, p, s)
    states = _section_states(beta[0], omega1[0], s)
    # every core inside the chunk: a chunk is a whole section and scene, and the slipping ones
    # are several times the others, so one thread per chunk leaves a core idle at the end
    sim = dict(t_max=t_max, rtol=s["rtol"], atol=s["atol"], method=s["method"], workers=None,
               **sections.engine_options(s))
    eps = eps_values(s["n_fine"], s["n_coarse"])
    if s["eps_pairs"] == "refined":
        codes, status, uncertain, runs = _refined(beta[0], omega1[0], params, s, sim, eps)
        return _pred_fields(codes, status, uncertain, np.ones(codes.shape), runs, s)
    res = solver.simulate(states, params, **sim)
    codes = res["outcome"]
    scale = np.array([beta[0, 1, 0] - beta[0, 0, 0], omega1[0, 0, 1] - omega1[0, 0, 0], 0.0, 0.0])
    uncertain, weight = pred.section_uncertainty(states, codes, params, eps, scale, n_sample=int(s["n_sample"]),
                                                 seed=int(s["seed"]), **sim)
    runs = np.where(weight > 0, 4 * int((eps < 1).sum()), 0).astype(np.int32)
    return _pred_fields(codes, res["status"], uncertain, weight, runs, s)


def _pred_fields(codes, status, uncertain, weight, runs, s) -> dict:
    """The chunk's variables from the outcome grid and its eps-uncertain flags."""
    box = int(s["box"])
    per_box = pred.box_entropy(codes, box)
    entropy = np.full(codes.shape, np.nan)
    nb, nw = per_box.shape
    entropy[: nb * box, : nw * box] = np.repeat(np.repeat(per_box, box, axis=0), box, axis=1)
    bits = (uncertain.astype(np.int64) << np.arange(uncertain.shape[0])[:, None, None]).sum(axis=0)
    return {"outcome": codes[None], "box_entropy": entropy[None], "uncertain": bits[None].astype(np.int32),
            "sample_weight": weight[None], "eps_runs": runs[None], "status": status[None]}


PRED_VARIABLES = [
    _outcome_var(),
    Var("box_entropy", "1", "Shannon entropy [nats] of the outcome fractions in the box (box x box grid points) "
        "holding this point; NaN outside whole boxes", pointwise=False),
    Var("uncertain", "1", "bit i set: the outcome changes when beta or omega1 moves by +-eps[i] grid steps "
        "(eps[i] = 2**(i - n_fine)); bits of eps < 1 are known where sample_weight > 0", dtype="int32",
        pointwise=False),
    Var("sample_weight", "1", "grid points this point stands for in the eps < 1 test (0: not simulated)",
        pointwise=False),
    Var("eps_runs", "1", "states simulated for this point's eps < 1 test: eps_pairs = sampled, 4 per eps "
        "below one grid step at a sampled point; eps_pairs = refined, the points of the refined grid simulated "
        "in the 2**n_fine x 2**n_fine block at this point (the point itself excluded)", dtype="int32",
        compared=False, pointwise=False),
    output_var("status", long_name="integration status of the nominal state"),
]


def _lead(ds, name):
    """``ds[name]`` as (lead..., beta, omega1) numpy plus the lead dims."""
    da = ds[name]
    lead = [d for d in da.dims if d not in ("beta", "omega1")]
    return da.transpose(*lead, "beta", "omega1").values, lead


N_BOOT = 1000
"""Bootstrap replicates of alpha per section and scene (``solver.analysis.exponent_bootstrap``)."""


def boot_comment(refined: bool) -> str:
    """The comment of the bootstrap variables: how the points below one grid step were tested."""
    below = ("every grid point, its pairs read from the refined map (eps_pairs = refined)" if refined else
             "the two-phase sample of section_uncertainty: the edge points and the random sample of the rest")
    return (f"{N_BOOT} replicates (solver.analysis.exponent_bootstrap, seed = the run's seed + the panel's "
            f"index): each draws the grid's points with replacement (Poisson bootstrap; below one grid step {below}) "
            "and fits alpha as the nominal estimate does, on the whole eps range and on a contiguous window of at "
            "least 3 eps picked at random")


def _bootstrap(eps, bits, weight, n_eff, seed: int) -> tuple[float, float, float, float]:
    """(err over states, err over states and eps windows, 2.5 %, 97.5 %) of alpha of one panel, from its
    uncertain bits and sample weights (``exponent_bootstrap.bootstrap_exponent``)."""
    u = np.stack([((bits >> j) & 1).astype(bool).ravel() for j in range(eps.size)])
    rest = ~u[int(np.argmin(np.abs(np.log(eps))))]  # certain at one grid step
    sampled = weight.ravel() > 0 if (eps < 1).any() else np.ones(rest.shape, dtype=bool)
    b = boot.bootstrap_exponent(eps, u, sampled, rest, n_eff, n_boot=N_BOOT, seed=seed)
    return b.err_states, b.err, b.low, b.high


STRATA = "strata: the points uncertain at one grid step and the others;"


def _refined_file(ds) -> bool:
    """Whether a predictability file tested eps < 1 on the refined map (files before the setting: sampled)."""
    try:
        return str(setting_of(ds, "eps_pairs")) == "refined"
    except KeyError:
        return False


def _pred_derive(ds):
    codes, lead = _lead(ds, "outcome")
    bits, _ = _lead(ds, "uncertain")
    weight, _ = _lead(ds, "sample_weight")
    shape = codes.shape[:-2]
    eps = eps_values(setting_of(ds, "n_fine"), setting_of(ds, "n_coarse"))
    box = int(setting_of(ds, "box"))
    refined = _refined_file(ds)
    comment = boot_comment(refined)
    def flat(a):
        return a.reshape((-1,) + a.shape[-2:])
    n = int(np.prod(shape, dtype=int))
    s_b, s_bb, n_bb = np.empty(n), np.empty(n), np.empty(n, dtype=np.int32)
    f, f_err = np.empty((n, eps.size)), np.empty((n, eps.size))
    alpha, alpha_err = np.empty(n), np.empty(n)
    spread = np.empty((n, 4))  # bootstrap: err over states, err over states and eps windows, 95 % interval
    seed = int(setting_of(ds, "seed"))
    for i, (c, b, w) in enumerate(zip(flat(codes), flat(bits), flat(weight))):
        be = pred.basin_entropy(c, box)
        s_b[i], s_bb[i], n_bb[i] = be.S_b, be.S_bb, be.n_boundary_boxes
        edge = (b >> int(np.argmin(np.abs(np.log(eps))))) & 1  # uncertain at one grid step: the first stratum
        for j, e in enumerate(eps):
            f[i, j], f_err[i, j] = pred.sampled_fraction((b >> j) & 1, w if e < 1 else None, edge if e < 1 else None)
        with np.errstate(divide="ignore", invalid="ignore"):
            n_eff = np.where(f_err[i] > 0, f[i] * (1 - f[i]) / f_err[i] ** 2, 0.0)
        ex = pred.uncertainty_exponent(eps, f[i], n_eff)
        alpha[i], alpha_err[i] = ex.alpha, ex.alpha_err
        spread[i] = _bootstrap(eps, b, w, n_eff, seed + i)
    lead, dims_eps = tuple(lead), tuple(lead) + ("eps",)
    def r(a):
        return a.reshape(shape)

    def re(a):
        return a.reshape(shape + (eps.size,))
    return {
        "eps": (("eps",), eps, {"units": "1", "long_name": "perturbation size in grid steps of beta and omega1"}),
        "S_b": (lead, r(s_b), {"units": "1", "long_name": "basin entropy: mean box entropy over all boxes [nats]"}),
        "S_bb": (lead, r(s_bb), {"units": "1", "long_name": "boundary basin entropy: mean box entropy over boxes "
                                 "with more than one outcome [nats]; above ln 2 = 0.693 the boundary is fractal"}),
        "n_boundary_boxes": (lead, r(n_bb), {"units": "1", "long_name": "boxes holding more than one outcome"}),
        "f": (dims_eps, re(f), {"units": "1", "long_name": "fraction of states whose outcome changes under a "
                                "+-eps perturbation of beta or omega1 (uncertain fraction f(eps))"}),
        "f_err": (dims_eps, re(f_err), {"units": "1", "long_name": "standard error of f (binomial, stratified)",
                                        "comment": STRATA + (" every point tested (eps_pairs = refined)" if refined
                                                             else " below one grid step the second stratum is a "
                                                                  "random sample (sample_weight)")}),
        "alpha": (lead, r(alpha), {"units": "1", "long_name": "uncertainty exponent: slope of log f against "
                                   "log eps (1: smooth boundary, < 1: fractal)"}),
        "alpha_err": (lead, r(alpha_err), {"units": "1", "long_name": "standard error of alpha (the fit's)"}),
        "alpha_err_states": (lead, r(spread[:, 0]), {
            "units": "1", "long_name": "bootstrap error of alpha: standard deviation over resamplings of the states, "
                                       "whole eps range", "comment": comment}),
        "alpha_err_bootstrap": (lead, r(spread[:, 1]), {
            "units": "1", "long_name": "bootstrap error of alpha: standard deviation over resamplings of the states "
                                       "and of the eps range fitted", "comment": comment}),
        "alpha_low": (lead, r(spread[:, 2]), {
            "units": "1", "long_name": "2.5 % percentile of alpha over resamplings of the states and the eps range",
            "comment": comment}),
        "alpha_high": (lead, r(spread[:, 3]), {
            "units": "1", "long_name": "97.5 % percentile of alpha over resamplings of the states and the eps range",
            "comment": comment}),
        "D": (lead, r(2 - alpha), {"units": "1", "long_name": "box dimension of the outcome boundaries in the "
                                   "(beta, omega1) section, 2 - alpha"}),
    }


def _pred_plot(ds):
    sections = ds["omega2"].values if "omega2" in ds.dims else [float(setting_of(ds, "omega2"))]
    rows = len(sections)
    fig, _ = P.new_figure(15.0, 3.9 * rows + 0.8)
    fig.clear()
    axes = np.atleast_2d(fig.subplots(rows, 3, squeeze=False))
    scenes = [P.scene_text(v) for v in ds["scene"].values]
    styles = ("o-", "s--", "^-.", "v:")
    w1, beta = ds["omega1"].values, ds["beta"].values
    emax = np.log(max(2, len(OUTCOME_NAMES)))
    partial = False
    for r, om in enumerate(sections):
        sec = ds.sel(omega2=om) if "omega2" in ds.dims else ds
        ax = axes[r, 0]
        eps = sec["eps"].values
        for k in range(sec.sizes["scene"]):
            sc = sec.isel(scene=k)
            f, err = sc["f"].values, sc["f_err"].values
            a, ae = float(sc["alpha"]), float(sc["alpha_err"])
            colour = f"C{k}"
            ok = f > 0
            # the bootstrap's 95 % interval where the file has it (files written before: the fit's error)
            spread = (rf" [{float(sc['alpha_low']):.2f}, {float(sc['alpha_high']):.2f}]" if "alpha_low" in sc
                      else "")
            ax.errorbar(eps[ok], f[ok], yerr=err[ok], fmt=styles[k % 4], color=colour, ms=4, lw=1.2, capsize=2,
                        label=rf"{scenes[k] if k < len(scenes) else k}: $\alpha$={a:.3f}$\pm${ae:.3f}{spread}")
            if np.isfinite(a) and ok.sum() >= 2:
                # the fitted line through the weighted centre of the points
                le, lf = np.log(eps[ok]), np.log(f[ok])
                c = lf.mean() - a * le.mean()
                ax.plot(eps, np.exp(c) * eps ** a, "-", color=colour, lw=0.6, alpha=0.7)
        ax.plot(eps, f[ok][-1] * eps / eps[ok][-1] if ok.any() else eps * np.nan, "k:", lw=0.8, label="slope 1")
        ax.set_xscale("log")
        ax.set_yscale("log")
        ax.xaxis.set_major_locator(FixedLocator(eps))
        ax.xaxis.set_major_formatter(FuncFormatter(lambda e, _: f"{e:g}" if e >= 1 else f"1/{1 / e:g}"))
        ax.xaxis.set_minor_locator(NullLocator())
        ax.set_xlabel(r"perturbation $\varepsilon$ [grid steps of $\beta$, $\omega_1$]")
        ax.set_ylabel(r"uncertain fraction $f(\varepsilon)$ [-]")
        ax.set_title(rf"$\omega_2$={om:g} 1/s: $f(\varepsilon)\sim\varepsilon^\alpha$", fontsize=10)
        ax.grid(alpha=0.3, which="both")
        ax.legend(fontsize=7.5, loc="best")  # the curves rise to the right: the legend finds the empty corner
        for col, k in ((1, 0), (2, 1)):
            ax = axes[r, col]
            sc = sec.isel(scene=k)
            ent = sc["box_entropy"].transpose("beta", "omega1").values
            if np.isnan(ent).any():  # rows or columns beyond the last whole box: hatched, not blank
                ax.add_patch(Rectangle((0, 0), 1, 1, transform=ax.transAxes, fc="white", ec="0.6", hatch="///",
                                       lw=0, zorder=0))
                partial = True
            mesh = ax.pcolormesh(w1, beta, ent, cmap="magma_r", vmin=0, vmax=emax, shading="nearest",
                                 rasterized=True)
            ax.set_title(rf"box entropy, {scenes[k]}: $S_b$={float(sc['S_b']):.4f}, "
                         rf"$S_{{bb}}$={float(sc['S_bb']):.3f} (ln 2 = 0.693)", fontsize=9)
            ax.set_xlabel(r"$\omega_1$ [1/s]")
            ax.set_ylabel(r"$\beta$ [rad]")
        fig.colorbar(mesh, ax=axes[r, 1:], label="box entropy [nats]", shrink=0.9)
    box = int(setting_of(ds, "box"))
    below = (f"read for every point from the section refined {2 ** int(setting_of(ds, 'n_fine'))} times"
             if _refined_file(ds) else
             "simulated on a stratified sample")
    fig.suptitle(f"{ds.attrs['title']}\nuncertain fraction f (whole eps read from the grid, eps < 1 {below}; "
                 f"lines: fitted slopes) and entropy of {box} x {box} boxes"
                 + ("; hatched: beyond the last whole box" if partial else ""), fontsize=11)
    return fig


register(Study(
    name="predictability",
    title="Predictability of the outcome sections (Figs. 11-13): basin entropy and uncertainty exponent",
    settings=PRED_SETTINGS,
    quick=PRED_QUICK,
    sweepable=("omega2",),
    axes=_pred_axes,
    variables=PRED_VARIABLES,
    compute=_pred_compute,
    plot=_pred_plot,
    chunks={"scene": 1, "beta": 1 << 30, "omega1": 1 << 30},  # a chunk is one scene's whole section
    derive=_pred_derive,
    derived_docs=(
        ("eps", "1", "coordinate: perturbation size in grid steps of beta and omega1"),
        (("S_b", "S_bb"), "1", "basin entropy over all boxes / over boxes with more than one outcome [nats]; "
                               "S_bb above ln 2 = 0.693: a fractal boundary"),
        ("n_boundary_boxes", "1", "boxes holding more than one outcome"),
        (("f", "f_err"), "1", "uncertain fraction f(eps) and its standard error (over `eps`)"),
        (("alpha", "alpha_err", "D"), "1", "uncertainty exponent (slope of log f against log eps), the fit's "
                                           "standard error, and the boundary dimension D = 2 - alpha"),
        (("alpha_err_states", "alpha_err_bootstrap", "alpha_low", "alpha_high"), "1",
         "bootstrap of alpha: its standard deviation over resamplings of the states (whole eps range), and over "
         "resamplings of the states and of the eps range fitted, with the 95 % interval of the latter"),
    ),
    # README "Predictability of a shot": ~250 s CPU for the 12 sections x scenes of 86,400 points
    cost=2.5e-4, compiles=True,
    # eps_pairs = refined: 5x (README, Fig. 12 at 240 x 360: 198 s CPU against 40 s)
    cost_factor=lambda s: 5.0 if s.get("eps_pairs") == "refined" else 1.0,
    ignores=sections.SCENE_IGNORES,
    # a regression reference at the study's own settings: box entropies and eps-uncertain flags count
    # outcome changes within a grid step, so a tighter rtol moves them only where the outcomes differ;
    # the default slice is a 24 x 36 sub-grid of every section and scene
    reference=ReferenceSpec({"beta": 24, "omega1": 36}, method="solver.simulate at the study's rtol and method"),
))


# ================================================================ make-probability
PROB_SETTINGS = {
    "omega2": 35.0, "omega3": 10.0,  # [1/s] the Fig. 11 section
    "beta_min": 0.8, "beta_max": 1.8, "n_beta": 240,  # [rad]
    "omega1_max": 20.0, "n_omega1": 360,  # [1/s]
    "mu": float("inf"),  # rolling only unless set
    "sigma": 1.0,  # noise level: multiplies the four spreads below
    "sigma_beta": 0.02,  # [rad] about 1.1 degrees, 2.6 mm of the contact point on the rim's tube
    "sigma_omega1": 1.0, "sigma_omega2": 2.0, "sigma_omega3": 1.0,  # [1/s]
    "n_samples": 64, "seed": 0, "confidence": 0.95,
    "t_max": 20.0, "rtol": 1e-6, "atol": 1e-9, "method": "auto",
    "delta": sections.SETTINGS["delta"], "slip_method": sections.SETTINGS["slip_method"],
}
PROB_QUICK = {"n_beta": 24, "n_omega1": 36, "n_samples": 16}


def _prob_axes(s):
    if s["n_beta"] < 2 or s["n_omega1"] < 2:
        raise ValueError(f"n_beta and n_omega1 must be >= 2; got {s['n_beta']}, {s['n_omega1']}")
    if s["n_samples"] < 1:
        raise ValueError(f"n_samples must be >= 1; got {s['n_samples']}")
    if not 0 < s["confidence"] < 1:
        raise ValueError(f"confidence must lie in (0, 1); got {s['confidence']}")
    spreads = [s[k] for k in ("sigma_beta", "sigma_omega1", "sigma_omega2", "sigma_omega3")]
    if not all(np.isfinite(v) and v >= 0 for v in spreads):
        raise ValueError(f"sigma_beta, sigma_omega1, sigma_omega2, sigma_omega3 must be finite and >= 0; got {spreads}")
    w = float(s["omega1_max"])
    return [Axis("beta", np.linspace(s["beta_min"], s["beta_max"], int(s["n_beta"])), "rad", "nominal height angle",
                 comment="nominal " + sections.BETA_COMMENT),
            Axis("omega1", np.linspace(-w, w, int(s["n_omega1"])), "s-1", "nominal omega1",
                 comment="nominal " + sections.OMEGA1_COMMENT)]


def sigma_of(s) -> np.ndarray:
    """Standard deviations (rad, 1/s, 1/s, 1/s) of the arriving state: sigma times the sigma_* settings."""
    return float(s["sigma"]) * np.array([s["sigma_beta"], s["sigma_omega1"], s["sigma_omega2"], s["sigma_omega3"]])


def _prob_compute(coords, p, s):
    beta, omega1 = coords
    states = _section_states(beta, omega1, s)
    sim = dict(t_max=s["t_max"], rtol=s["rtol"], atol=s["atol"], method=s["method"], workers=1,
               **sections.engine_options(s))
    res = pred.make_probability(states, p, sigma_of(s), n_samples=int(s["n_samples"]), seed=int(s["seed"]),
                                confidence=float(s["confidence"]), **sim)
    out = {"outcome": solver.simulate(states, p, **sim)["outcome"], "n_failed": res["n_failed"]}
    codes = res["codes"].tolist()
    for code, name in OUTCOME_NAMES.items():
        i = codes.index(code)
        out[f"p_{name}"] = res["probability"][..., i]
        out[f"p_{name}_lower"] = res["lower"][..., i]
        out[f"p_{name}_upper"] = res["upper"][..., i]
    return out


def _prob_variables():
    out = [_outcome_var()]
    for name in OUTCOME_NAMES.values():
        out += [Var(f"p_{name}", "1", f"probability of {name} when the arriving state is normal around the "
                    "nominal one (Monte Carlo, common random numbers)"),
                Var(f"p_{name}_lower", "1", f"lower end of the Wilson confidence interval of p_{name}"),
                Var(f"p_{name}_upper", "1", f"upper end of the Wilson confidence interval of p_{name}")]
    out.append(Var("n_failed", "1", "samples whose integration status is not ok (counted by their outcome)",
                   dtype="int32"))
    return out


def _first_outer(da):
    for d in list(da.dims):
        if d not in ("beta", "omega1"):
            da = da.isel({d: 0})
    return da.transpose("beta", "omega1")


def _prob_plot(ds):
    dims = C.swept(ds)
    fig = Figure(figsize=(16.0, 5.2 + (3.9 if dims else 0.0)), layout="constrained")
    top = fig.subfigures(2, 1, height_ratios=[5.2, 3.9])[0] if dims else fig
    if dims:  # every swept axis: the mean probability of each outcome over the section against it
        bottom = fig.subfigs[1]
        panels = list(np.atleast_1d(bottom.subplots(1, len(dims), sharey=True)))
        series = [(PALETTE.label(code), ds[f"p_{name}"].mean(("beta", "omega1")), PALETTE.colour(code))
                  for code, name in OUTCOME_NAMES.items()]
        handles = C.sweep_panels(panels, ds, series, "mean probability over the section [-]", ylim=(-0.02, 1.02))
        bottom.legend(handles=handles, loc="outside right upper", fontsize=8)
    axes = top.subplots(1, 3, sharey=True)
    w1, beta = ds["omega1"].values, ds["beta"].values
    codes = _first_outer(ds["outcome"]).values
    handles = _outcome_map(axes[0], w1, beta, codes)
    axes[0].set_title("deterministic outcome (sigma = 0)", fontsize=10)
    axes[0].legend(handles=handles, fontsize=8, loc="lower left")
    p_in = _first_outer(ds["p_fall_in"]).values
    mesh = axes[1].pcolormesh(w1, beta, p_in, cmap="RdBu", vmin=0, vmax=1, shading="nearest", rasterized=True)
    axes[1].contour(w1, beta, p_in, levels=[0.5], colors="k", linewidths=1.2)
    inside = (codes == outcomes.FALL_IN).astype(float)
    if 0 < inside.mean() < 1:
        axes[1].contour(w1, beta, inside, levels=[0.5], colors="yellow", linewidths=0.8, linestyles="--")
    fig.colorbar(mesh, ax=axes[1], label="P(fall in)")
    axes[1].set_title("P(fall in): black P = 0.5, yellow dashed the deterministic boundary", fontsize=10)
    stay = sum(_first_outer(ds[f"p_{name}"]).values for code, name in OUTCOME_NAMES.items()
               if code not in (outcomes.FALL_IN, outcomes.FALL_OUT))
    mesh = axes[2].pcolormesh(w1, beta, stay, cmap="Greens", vmin=0, vmax=1, shading="nearest", rasterized=True)
    fig.colorbar(mesh, ax=axes[2], label="P(stays on the rim)")
    axes[2].set_title("P(periodic rolling or still on the rim)", fontsize=10)
    for ax in axes:
        ax.set_xlabel(r"nominal $\omega_1$ [1/s]")
    axes[0].set_ylabel(r"nominal $\beta$ [rad]")
    s = {k: float(setting_of(ds, k)) for k in ("sigma_beta", "sigma_omega1", "sigma_omega2", "sigma_omega3")}
    level = float(ds["sigma"][0]) if "sigma" in ds.dims else float(setting_of(ds, "sigma"))
    outer = [f"{d}={float(ds[d][0]):g}" for d in ds["p_fall_in"].dims if d not in ("beta", "omega1")]
    omega2 = float(ds["omega2"][0]) if "omega2" in ds.dims else float(setting_of(ds, "omega2"))
    fig.suptitle(rf"Make probability at $\omega_2$={omega2:g} 1/s: "
                 rf"$\sigma$ = {level:g} x ({s['sigma_beta']:g} rad, {s['sigma_omega1']:g}, {s['sigma_omega2']:g}, "
                 rf"{s['sigma_omega3']:g} 1/s), {int(setting_of(ds, 'n_samples'))} samples per state"
                 + (f"\nmaps: the first value of each swept axis, {', '.join(outer)} (study plot FILE --select ... "
                    "draws another); below: every swept axis" if outer else ""), fontsize=11)
    return fig


register(Study(
    name="make-probability",
    title="Make probability of a throw with a normal spread of the arriving state over the (beta, omega1) section",
    settings=PROB_SETTINGS,
    quick=PROB_QUICK,
    sweepable=("sigma", "mu", *TERM_KEYS, "omega2", "omega3"),
    # README "Predictability of a shot": ~50 s CPU for 86,400 states x 64 samples; per point at the
    # --quick 16 samples: 1.5e-4 s
    cost=1.5e-4, cost_scale="n_samples", compiles=True,
    axes=_prob_axes,
    variables=_prob_variables(),
    compute=_prob_compute,
    plot=_prob_plot,
    chunks={"beta": 12},
    # a regression reference at the study's own settings: a probability is a count of n_samples
    # seeded draws, each an outcome; a 12 x 18 sub-grid of the default section
    reference=ReferenceSpec({"beta": 12, "omega1": 18}, method="solver.simulate at the study's rtol and method"),
))
