"""Work-precision of the outcome engine against scipy (docs/work-precision.md).

One seeded sample of initial states from the three outcome sections (omega2 = 35, 65,
105 1/s; omega3 = 10 1/s; beta in [0.8, 1.8] rad; omega1 in [-20, 20] 1/s) is run in every
scene by each method at each tolerance, in the same process at the same moment: rimroll's
compiled DP5 and DOP853 and scipy's ``solve_ivp`` RK45, DOP853 and LSODA (same right-hand
side, same event rules: ``solver.analysis.scipy_reference``), and where heyoka is installed (the extra
rimroll[bench]) heyoka's Taylor integrator in the rolling-only scene (``heyoka_rolling``; NaN in
the other scenes). The reference is rimroll's DOP853 at rtol = 1e-12. Recorded per (scene,
integrator, rtol): seconds per trajectory (one thread), misclassified fraction, |t_end| error
(median, max), median energy drift.

Timings exclude compilation (each kernel is warmed up first, scipy too). scipy runs the first
``n_scipy`` states of the sample that stay on the rim past t = 0 (about half the sample falls at
once, F2 < 0) in the rolling-only scene and the first ``n_scipy_hybrid`` in the slipping scenes
(scipy is slow, most of all through slip phases); its figures are per trajectory, and
``seconds_per_trajectory_common`` times rimroll on exactly those states, so speed ratios compare
the same work. t_end errors are taken over the states that were integrated (t_end of the
reference > 0). Only the timings vary from run to run: ``study verify`` compares the rest.
"""

from __future__ import annotations

import time

import numpy as np
from matplotlib.figure import Figure

from rimroll import solver
from rimroll.peer_models import heyoka_rolling
from rimroll.solver.analysis import scipy_reference
from rimroll.study import plotting as P
from rimroll.study.outcome_sections import SCENE_IGNORES, SCENES, scene_axis, scene_index, scene_params
from rimroll.study.registry import Axis, ReferenceSpec, Study, Var, register

REDUCED = "rimroll_reduced"
INTEGRATORS = ("rimroll_dp5", "rimroll_dop853", "scipy_rk45", "scipy_dop853", "scipy_lsoda") + (
    (heyoka_rolling.LABEL,) if heyoka_rolling.available() else ()) + (REDUCED,)
"""Labels of the ``integrator`` coordinate: rimroll's compiled methods, scipy's solve_ivp, heyoka's
Taylor integrator where heyoka is installed (the extra rimroll[bench]), then rimroll's exact reduced
solver of the rolling-only scene."""
REDUCED_TEXT = (f"; {REDUCED} = rimroll's exact reduced solver (solver.simulate method='reduced', "
                "docs/explanation/exact-rolling.md): a quadrature, not an integration, so rtol changes nothing but "
                "the rule of a transversal omega1 zero; it runs the rolling-only scene only, its values in the other "
                "scenes are NaN")
HEYOKA_TEXT = (f"; {heyoka_rolling.LABEL} = heyoka's Taylor integrator, batch mode on one thread, tol = rtol "
               "(rimroll.peer_models.heyoka_rolling); it runs the rolling-only scene only, its values in the other "
               "scenes are NaN: its model is that scene (mu = inf, k_r = k_d = 0)")
OURS = {"rimroll_dp5": "dp5", "rimroll_dop853": "dop853"}
SCIPY = {"scipy_rk45": "RK45", "scipy_dop853": "DOP853", "scipy_lsoda": "LSODA"}
REFERENCE_RTOL = 1e-12
ATOL_OVER_RTOL = 1e-2  # atol = 1e-2 * rtol for every method (state scales ~1 rad, ~10 1/s)

SETTINGS = {
    "n_states": 240, "n_scipy": 12, "n_scipy_hybrid": 4, "seed": 20261122,
    "rtol_max": 1e-4, "rtol_min": 1e-12, "n_rtol": 9,
    "omega3": 10.0, "mu_slip": 1.0, "k_dissipation": 0.02,
    "t_max": 10.0, "t_max_dissipative": 30.0,
}
QUICK = {"n_states": 120, "n_scipy": 8, "n_scipy_hybrid": 3, "rtol_max": 1e-2, "n_rtol": 4, "rtol_min": 1e-8,
         "t_max": 5.0, "t_max_dissipative": 10.0}
"""A quick run that shows something: 120 states, scipy on 8 rolling-only and 3 slipping ones, and rtol
from 1e-2, loose enough that some outcomes change (the misclassification row is not all zeros)."""

VARIABLES = [
    Var("seconds_per_trajectory", "s", "wall time per trajectory on one thread, compile time excluded",
        compared=False),
    Var("misclassified_fraction", "1", "fraction of states whose outcome differs from the reference"),
    Var("t_end_error_median", "s", "median |t_end - t_end_reference| over integrated states (reference t_end "
        "> 0) with the reference outcome"),
    Var("t_end_error_max", "s", "largest |t_end - t_end_reference| over integrated states (reference t_end "
        "> 0) with the reference outcome"),
    Var("energy_drift_median", "1", "median relative energy change over the run (conservative scenes: drift)"),
    Var("n_trajectories", "1", "number of states run", dtype="int32"),
    Var("seconds_per_trajectory_common", "s", "wall time per trajectory on the states scipy also runs (the "
        "first n_scipy that stay on the rim past t = 0), one thread", compared=False),
]


def sample_states(s: dict) -> np.ndarray:
    """The seeded sample (n_states, 4) of initial states from the three outcome sections."""
    rng = np.random.default_rng(int(s["seed"]))
    n = int(s["n_states"])
    return np.column_stack([rng.uniform(0.8, 1.8, n), rng.uniform(-20.0, 20.0, n),
                            rng.choice([35.0, 65.0, 105.0], n), np.full(n, float(s["omega3"]))])


def _axes(s: dict) -> list[Axis]:
    rtols = np.geomspace(float(s["rtol_max"]), float(s["rtol_min"]), int(s["n_rtol"]))
    return [
        scene_axis(s),
        Axis("integrator", np.array(INTEGRATORS), "", "integration method: rimroll_dp5 / rimroll_dop853 = rimroll's "
             "compiled Dormand-Prince 5(4) / 8(5,3); scipy_rk45 / scipy_dop853 / scipy_lsoda = scipy.integrate."
             "solve_ivp with RK45 / DOP853 / LSODA on the same equations and event rules"
             + (HEYOKA_TEXT if heyoka_rolling.LABEL in INTEGRATORS else "") + REDUCED_TEXT),
        Axis("rtol", rtols, "1", "relative tolerance", comment="relative tolerance of the run (atol = 1e-2 rtol)"),
    ]


def _scene_params(p: solver.Params, s: dict, k: int) -> tuple[solver.Params, float]:
    return scene_params(p, s, SCENES[k])


def _ours(states, params, t_max, rtol, method, min_seconds=0.05):
    """Results and seconds per trajectory (best of repeats lasting >= min_seconds in all; warm)."""
    kwargs = dict(t_max=t_max, rtol=rtol, atol=rtol * ATOL_OVER_RTOL, method=method, workers=1)
    solver.simulate(states[:1], params, **kwargs)  # compiled or loaded from cache: not timed
    best, spent = np.inf, 0.0
    while spent < min_seconds or best == np.inf:
        start = time.perf_counter()
        res = solver.simulate(states, params, **kwargs)
        elapsed = time.perf_counter() - start
        best, spent = min(best, elapsed), spent + elapsed
    return res, best / len(states)


def _refused(states, params, t_max) -> bool:
    """Whether the reduced solver refuses the scene of ``params`` (it runs the conservative rolling-only one)."""
    try:
        solver.simulate(states[:1], params, t_max=t_max, method="reduced", workers=1)
    except ValueError:
        return True
    return False


def _heyoka(states, params, t_max, rtol, min_seconds=0.05):
    """heyoka's results and seconds per trajectory, as :func:`_ours` times rimroll (one thread, warm)."""
    integrator = heyoka_rolling.Integrator(params, rtol)  # compiled or loaded from heyoka's cache: not timed
    best, spent = np.inf, 0.0
    while spent < min_seconds or best == np.inf:
        start = time.perf_counter()
        res = heyoka_rolling.classify(states, integrator, t_max)
        elapsed = time.perf_counter() - start
        best, spent = min(best, elapsed), spent + elapsed
    return {**res, "energy_drift": heyoka_rolling.energy_drift(states, res, params)}, best / len(states)


def _scipy(states, params, t_max, rtol, method, min_seconds=0.2):
    """scipy's results and seconds per trajectory, warm (a first call pays for imports and the first
    use of the compiled right-hand sides: it made the first rtol of a sweep look slow) and the best
    of repeats while they last less than ``min_seconds`` in all."""
    kwargs = dict(t_max=t_max, rtol=rtol, atol=rtol * ATOL_OVER_RTOL, method=method)
    scipy_reference.reference(states[:1], params, **dict(kwargs, t_max=min(t_max, 0.1)))  # warm-up: not timed
    best, spent = np.inf, 0.0
    while best == np.inf or spent < min_seconds:
        start = time.perf_counter()
        res = scipy_reference.reference(states, params, **kwargs)
        elapsed = time.perf_counter() - start
        best, spent = min(best, elapsed), spent + elapsed
    return res, best / len(states)


def _scores(res, ref, seconds):
    same = res["outcome"] == ref["outcome"]
    # t_end errors over the states that were integrated: about half the sample falls at t = 0 (F2 < 0
    # at once), with no error to speak of, and those zeros made the median 0
    err = np.abs(res["t_end"] - ref["t_end"])[same & (ref["t_end"] > 0)]
    drift = res.get("energy_drift")
    return {
        "seconds_per_trajectory": seconds,
        "misclassified_fraction": 1.0 - same.mean(),
        "t_end_error_median": float(np.median(err)) if err.size else np.nan,
        "t_end_error_max": float(err.max()) if err.size else np.nan,
        "energy_drift_median": float(np.median(drift)) if drift is not None else np.nan,
        "n_trajectories": len(same),
    }


def _compute(coords, p: solver.Params, s: dict) -> dict:
    scene, integrator, rtol = coords
    shape = scene.shape
    out = {v.name: np.full(shape, np.nan) for v in VARIABLES}
    out["n_trajectories"] = np.zeros(shape, dtype=np.int32)
    states = sample_states(s)
    for label in np.unique(scene):
        k = scene_index(label)
        params, t_max = _scene_params(p, s, k)
        ref, _ = _ours(states, params, t_max, REFERENCE_RTOL, "dop853")
        # scipy runs the first states that stay on the rim past t = 0: a state that falls at once costs
        # nothing and tells nothing about an integrator
        common = np.flatnonzero(ref["t_end"] > 0)[: int(s["n_scipy"] if params.rolling_only else s["n_scipy_hybrid"])]
        n_scipy = common.size
        for name in np.unique(integrator):
            name = str(name)
            for r in np.unique(rtol):
                where = (scene == label) & (integrator == name) & (rtol == r)
                if name in OURS or name == REDUCED:
                    if name == REDUCED and _refused(states, params, t_max):
                        continue  # NaN: the reduced solver runs the conservative rolling-only scene only
                    method = OURS.get(name, "reduced")
                    res, sec = _ours(states, params, t_max, float(r), method)
                    scores = _scores(res, ref, sec)
                    if n_scipy:
                        scores["seconds_per_trajectory_common"] = _ours(states[common], params, t_max, float(r),
                                                                        method)[1]
                elif name == heyoka_rolling.LABEL:
                    if heyoka_rolling.unsupported(params):
                        continue  # NaN: the reason is in the integrator coordinate's long_name
                    res, sec = _heyoka(states, params, t_max, float(r))
                    scores = _scores(res, ref, sec)
                    if n_scipy:
                        scores["seconds_per_trajectory_common"] = _heyoka(states[common], params, t_max, float(r))[1]
                elif n_scipy:
                    res, sec = _scipy(states[common], params, t_max, float(r), SCIPY[name])
                    scores = _scores(res, {key: v[common] for key, v in ref.items()}, sec)
                    scores["seconds_per_trajectory_common"] = sec
                else:
                    continue
                for key, value in scores.items():
                    out[key][where] = value
    return out


STYLES = {"rimroll_dp5": ("C0", "o-"), "rimroll_dop853": ("C1", "s-"), "scipy_rk45": ("C2", "^--"),
          "scipy_dop853": ("C3", "v--"), "scipy_lsoda": ("C4", "d--"), heyoka_rolling.LABEL: ("C5", "P-"),
          REDUCED: ("C6", "*-")}
RTOL_NOTED = ("rimroll_dp5", "scipy_rk45")  # curves whose points carry their log10 rtol


def _integrator_dim(ds) -> str:
    """The file's integrator dimension: ``integrator`` (string labels) or, in older files, ``method``."""
    return "integrator" if "integrator" in ds.dims else "method"


def integrator_names(ds) -> list[str]:
    """Labels of :data:`INTEGRATORS` along the file's integrator dimension (e.g. rimroll_dp5,
    scipy_rk45); older files (numeric ``method`` with ``method_name`` such as scipy_RK45, in the
    order of :data:`INTEGRATORS`) are read as the same labels."""
    dim = _integrator_dim(ds)
    if "method_name" in ds.coords:
        return [str(v).lower() for v in ds["method_name"].values]
    values = ds[dim].values
    if values.dtype.kind in "USO":
        return [str(v).lower() for v in values]
    return [INTEGRATORS[int(v)] for v in values]


def _scene_position(ds, scene) -> int:
    """Position along ``scene`` of a scene label (e.g. ``"rolling_only"``) or of a position (int),
    for string-labelled files and older numeric ones alike."""
    if isinstance(scene, (int, np.integer)):
        return int(scene)
    keys = [P.scene_key(v) for v in ds["scene"].values]
    if scene not in keys:
        raise ValueError(f"no scene {scene!r} in this file; scenes: {', '.join(keys)}")
    return keys.index(scene)


def _count_text(ds, i: int) -> str:
    """'n states' of integrator i per scene kind: rolling only / slipping scenes (from n_trajectories)."""
    dim = _integrator_dim(ds)
    n = ds["n_trajectories"].isel({dim: i}).max("rtol").values  # per scene
    mu = ds["mu"].values
    roll = sorted({int(v) for v in n[np.isinf(mu)]})
    slip = sorted({int(v) for v in n[np.isfinite(mu)]})
    return f"{'/'.join(map(str, roll)) or '-'} rolling-only, {'/'.join(map(str, slip)) or '-'} slipping states"


def _plot(ds) -> Figure:
    dim = _integrator_dim(ds)
    names = integrator_names(ds)
    n_scene = ds.sizes["scene"]
    fig = Figure(figsize=(4.0 * n_scene, 8.0), layout="constrained")
    axes = fig.subplots(2, n_scene, sharey="row", squeeze=False)
    rtol = ds["rtol"].values
    for k in range(n_scene):
        top, bottom = axes[0, k], axes[1, k]
        for i, name in enumerate(names):
            sel = ds.isel({"scene": k, dim: i})
            colour, style = STYLES.get(name, ("0.3", "x:"))
            label = f"{name} ({_count_text(ds, i)})"
            x = sel["seconds_per_trajectory"].values
            y = sel["t_end_error_median"].values
            ok = np.isfinite(x) & np.isfinite(y) & (y > 0)
            if ok.any():
                top.loglog(x[ok], y[ok], style, color=colour, label=label, ms=4)
                if name in RTOL_NOTED:
                    for xi, yi, r in zip(x[ok], y[ok], rtol[ok]):
                        top.annotate(f"{np.log10(r):.0f}", (xi, yi), xytext=(3, 3), textcoords="offset points",
                                     fontsize=6.5, color=colour)
            m = sel["misclassified_fraction"].values
            okm = np.isfinite(m)
            if okm.any():
                bottom.semilogx(rtol[okm], m[okm], style, color=colour, label=label, ms=4)
        top.set_title(P.scene_text(ds["scene"].values[k]), fontsize=10)
        top.grid(True, which="both", alpha=0.3)
        top.set_xlabel("seconds per trajectory (one thread) [s]")
        bottom.set_xlabel("rtol [-] (atol = 1e-2 rtol)")
        bottom.invert_xaxis()
        worst = np.nanmax(ds["misclassified_fraction"].values) if np.isfinite(ds["misclassified_fraction"]).any() else 0
        bottom.set_ylim(-0.002, max(0.05, 1.1 * float(worst)))
        bottom.grid(True, which="both", alpha=0.3)
    axes[0, 0].set_ylabel(r"median $|t_{end} - t_{end}^{ref}|$ [s]" "\n(numbers: $\\log_{10}$ rtol)")
    axes[1, 0].set_ylabel("misclassified fraction of the states [-]")
    handles, labels = [], []
    for ax in axes.flat:
        for h, lbl in zip(*ax.get_legend_handles_labels()):
            if lbl not in labels:
                handles.append(h)
                labels.append(lbl)
    fig.legend(handles, labels, loc="outside lower center", ncol=3, fontsize=9, frameon=False)
    fig.suptitle(f"Work-precision: error and misclassification against cost; reference rimroll DOP853 at rtol "
                 f"{REFERENCE_RTOL:g}", fontsize=11)
    return fig


def speed_ratio(ds, scene: str = "rolling_only", rtol: float = 1e-8) -> float:
    """scipy RK45 seconds per trajectory over rimroll DP5's on the same states, at the rtol nearest ``rtol``."""
    sel = ds.isel(scene=_scene_position(ds, scene)).sel(rtol=rtol, method="nearest")
    names = integrator_names(ds)
    dim = _integrator_dim(ds)
    ours = float(sel["seconds_per_trajectory_common"].isel({dim: names.index("rimroll_dp5")}))
    theirs = float(sel["seconds_per_trajectory_common"].isel({dim: names.index("scipy_rk45")}))
    return theirs / ours


def _derive(ds) -> dict:
    """``speed_ratio_rk45_dp5`` per scene: the median over rtol of scipy RK45's seconds per trajectory
    over rimroll DP5's on the same states, with its spread over rtol in the attributes (a timing
    of one run on a possibly shared machine: compare ratios, not seconds)."""
    names = integrator_names(ds)
    if "rimroll_dp5" not in names or "scipy_rk45" not in names:
        return {}
    dim = _integrator_dim(ds)
    common = ds["seconds_per_trajectory_common"].transpose("scene", dim, "rtol").values
    with np.errstate(all="ignore"):
        ratio = common[:, names.index("scipy_rk45")] / common[:, names.index("rimroll_dp5")]  # (scene, rtol)
        med = np.nanmedian(np.where(np.isfinite(ratio), ratio, np.nan), axis=1)
        lo = np.nanmin(np.where(np.isfinite(ratio), ratio, np.nan), axis=1)
        hi = np.nanmax(np.where(np.isfinite(ratio), ratio, np.nan), axis=1)
    attrs = {"units": "1", "rimroll_compared": 0,  # a timing: study verify leaves it out
             "long_name": "scipy RK45 seconds per trajectory over rimroll DP5's on the same states (median over rtol)",
             "ratio_min_over_rtol": lo, "ratio_max_over_rtol": hi,
             "comment": "one run, one thread each, on the machine of the run: the spread over rtol "
                        "(ratio_min/max_over_rtol, per scene) bounds what a single number can claim"}
    return {"speed_ratio_rk45_dp5": (("scene",), med, attrs)}


register(Study(
    name="work-precision",
    title="Work-precision of the outcome engine against scipy solve_ivp",
    settings=SETTINGS,
    quick=QUICK,
    axes=_axes,
    variables=VARIABLES,
    compute=_compute,
    plot=_plot,
    chunks={"scene": 4, "integrator": len(INTEGRATORS)},
    derive=_derive,
    derived_docs=(("speed_ratio_rk45_dp5", "1", "per scene: scipy RK45 seconds per trajectory over rimroll DP5's "
                   "on the same states, median over rtol (spread in its attributes; "
                   "[work-precision.md](work-precision.md))"),),
    ignores=SCENE_IGNORES,  # the four named scenes set mu and the term parameters themselves
    cost=0.2, cost_scale="n_states", compiles=True,  # s per point at n_states 40 (--quick), on one core
    # the output is timing and what the timing buys: the slices hold the deterministic part (errors,
    # misclassification, drift; the timings are not compared), at rtol 1e-4, 1e-8, 1e-12 of the default
    reference=ReferenceSpec({"rtol": 3}, method="rimroll DOP853 at rtol 1e-12 against each integrator"),
))
