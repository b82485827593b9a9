"""What ``study info NAME`` and ``study run NAME --help`` say about a study before it runs.

What it computes (its title and its module's summary), every setting with its default, its
``--quick`` value, units and meaning, which settings ``--set`` can sweep, the grid (dimensions
and sizes at the defaults and with ``--quick``) and an estimate of the run time from
:data:`COST`, seconds per grid point measured on one core of the development machine.
"""

from __future__ import annotations

import inspect
import math
import os

from rimroll.study import registry
from rimroll.study.registry import PHYSICAL_KEYS, Study

SETTING_DOCS = {  # name: (units, meaning); units "" for counts, labels and switches
    "r": ("m", "radius of the ball"), "R": ("m", "major radius of the rim (torus)"),
    "a": ("m", "minor radius of the rim (tube)"), "m": ("kg", "mass of the ball"),
    "j": ("1", "moment of inertia J = j m r^2"), "mu": ("1", "Coulomb friction coefficient (inf: never slips)"),
    "g": ("m s-2", "gravitational acceleration"), "k_r": ("s-1", "rolling-resistance rate, paper (83)"),
    "k_d": ("s-1", "drilling-resistance rate, paper (83)"),
    "rho_over_R": ("1", "rho/R with R and a fixed (r = rho - a)"),
    "v_throw": ("m s-1", "throw speed whose kinetic energy bounds the steady motion (59)"),
    "omega2": ("s-1", "initial orthogonal angular velocity"), "omega3": ("s-1", "initial circular angular velocity"),
    "omega30": ("s-1", "circular angular velocity of the steady motion"),
    "omega30_max": ("s-1", "grid: omega30 in [-omega30_max, omega30_max]"),
    "omega1_max": ("s-1", "grid/sample: omega1 in [-omega1_max, omega1_max]"),
    "omega2_max": ("s-1", "sample: |omega2| <= omega2_max"), "omega3_max": ("s-1", "sample: |omega3| <= omega3_max"),
    "beta_min": ("rad", "grid: smallest initial beta"), "beta_max": ("rad", "grid: largest initial beta"),
    "beta0_min": ("rad", "smallest steady beta0"), "beta0_max": ("rad", "largest steady beta0"),
    "d_omega1": ("s-1", "perturbation of omega1 off the steady motion"),
    "mu_slip": ("1", "friction coefficient of the slipping scenes"),
    "k_dissipation": ("s-1", "rate k_d / k_r of the drilling / rolling-resistance scene"),
    "t_max": ("s", "end of a run still on the rim (conservative scenes)"),
    "t_max_dissipative": ("s", "end of a run still on the rim (dissipative scenes)"),
    "rtol": ("1", "relative tolerance of the integrator"), "atol": ("1", "absolute tolerance of the integrator"),
    "method": ("", "integrator: dp5 (Dormand-Prince 5(4)) or dop853"),
    "backend": ("", "where solver.simulate runs: cpu, cuda (a GPU; extra rimroll[gpu]) or auto"),
    "rtol_max": ("1", "loosest rtol of the sweep"), "rtol_min": ("1", "tightest rtol of the sweep"),
    "n_rtol": ("", "number of tolerances"), "seed": ("", "random seed of the sample"),
    "subset": ("", "which region of state space is sampled"),
    "n_scipy": ("", "states scipy runs, rolling only"), "n_scipy_hybrid": ("", "states scipy runs, slipping scenes"),
    "n_states": ("", "states in the sample"), "n_samples": ("", "states in the sample"),
    "n_trajectories": ("", "trajectories"), "n_time": ("", "output times per trajectory"),
    "n_beta0": ("", "grid points of beta0"), "n_omega30": ("", "grid points of omega30"),
    "n_beta": ("", "grid points of beta"), "n_omega1": ("", "grid points of omega1"),
    "n_j": ("", "grid points of j"), "n_rho_over_R": ("", "grid points of rho/R"),
    "box": ("", "grid points per side of a basin-entropy box"),
    "n_fine": ("", "eps below one grid step: 1/2 ... 1/2^n_fine (simulated)"),
    "n_coarse": ("", "eps of whole grid steps: 1 ... 2^n_coarse (read from the grid)"),
    "n_sample": ("", "states away from the grid's boundaries simulated for eps < 1"),
    "sigma": ("1", "noise level: multiplies sigma_beta ... sigma_omega3"),
    "sigma_beta": ("rad", "standard deviation of the arriving beta at sigma = 1"),
    "sigma_omega1": ("s-1", "standard deviation of the arriving omega1 at sigma = 1"),
    "sigma_omega2": ("s-1", "standard deviation of the arriving omega2 at sigma = 1"),
    "sigma_omega3": ("s-1", "standard deviation of the arriving omega3 at sigma = 1"),
    "confidence": ("1", "confidence level of the Wilson intervals"),
}

COST = {  # seconds per grid point on one core, warm: measured with --quick on 2 shared cores (2026-11)
    "fig3": 1e-7, "fig5": 1e-7, "fig6": 2e-6, "fig7": 1e-7, "fig8": 2e-6, "fig9": 1.5e-4,
    "fig11": 3e-4, "fig12": 3e-4, "fig13": 3e-4, "outcome-cube": 2e-4, "realisable-cube": 1e-6,
    "solution-types": 4e-2, "invariants": 2e-3, "work-precision": 0.2,
    # from README "Predictability of a shot": make-probability ~50 s CPU for 86,400 states x 64
    # samples (per point at the --quick 16 samples: 1.5e-4); predictability ~250 s CPU for the
    # 12 sections x scenes of 86,400 points
    "make-probability": 1.5e-4, "predictability": 2.5e-4,
}
SCALE = {  # the cost per point grows with this setting (measured at its --quick value)
    "work-precision": "n_states", "solution-types": "t_max", "invariants": "t_max",
    "make-probability": "n_samples",
}
COMPILES = ("fig11", "fig12", "fig13", "outcome-cube", "work-precision", "solution-types", "invariants",
            "predictability", "make-probability")
"""Studies whose first run in a fresh environment compiles the simulation kernels (cached afterwards)."""


def summary(study: Study) -> str:
    """First paragraph of the docstring of the module that defines the study's ``compute``."""
    module = inspect.getmodule(study.compute)
    doc = inspect.getdoc(module) or ""
    return " ".join(doc.split("\n\n")[0].split())


def _fmt(value) -> str:
    if isinstance(value, tuple):
        return ",".join(f"{v:g}" if isinstance(v, float) else str(v) for v in value)
    if isinstance(value, float):
        return f"{value:g}"
    return str(value)


def settings_lines(study: Study) -> list[str]:
    """One line per setting: name, default, --quick value, [units], meaning; physical parameters
    last, those the study ignores (``Study.ignores``, refused by ``--set``) in a final line."""
    from rimroll import solver
    table = {**{k: v for k, v in solver.Params().as_dict().items() if k not in study.settings}, **study.settings}
    keys = [*study.settings, *(k for k in PHYSICAL_KEYS if k not in study.settings and k not in study.ignores)]
    width = max(map(len, keys))
    lines = []
    for key in keys:
        units, meaning = SETTING_DOCS.get(key, ("", ""))
        text = f"  {key:<{width}}  {_fmt(table[key]):>12}"
        text += f"  (--quick {_fmt(study.quick[key])})" if key in study.quick else ""
        text += f"  [{units}]" if units else ""
        text += f"  {meaning}" if meaning else ""
        if key in study.sweepable:
            text += "  (sweepable)"
        lines.append(text)
    if study.ignores:
        reasons: dict = {}
        for key, why in study.ignores.items():
            reasons.setdefault(why, []).append(key)
        lines += [f"  not used (--set refuses them): {', '.join(keys)}: {why}" for why, keys in reasons.items()]
    return lines


def _grid(study: Study, quick: bool) -> tuple[str, int, int]:
    from rimroll.study.plan import make_plan

    plan = make_plan(study, quick)
    dims = " x ".join(f"{a.name} {a.values.size}" for a in plan.axes)
    return dims, math.prod(plan.shape), plan.n_chunks


def estimate(study: Study, points: int, workers: int, quick: bool = False) -> str:
    """Rough run time for ``points`` grid points on ``workers`` busy threads (at most one per
    chunk), from :data:`COST`
    (plus a few seconds of start-up and writing, not counted)."""
    if study.name not in COST:
        return "no estimate for this study"
    seconds = COST[study.name] * points / max(workers, 1)
    key = SCALE.get(study.name)
    if key and not quick:
        seconds *= float(study.settings[key]) / float(study.quick.get(key, study.settings[key]))
    text = f"about {seconds:.0f} s" if seconds >= 1 else "under a second"
    if study.name in COMPILES:
        text += " (a first run in a fresh environment also compiles the simulation kernels, 1-2 min, cached)"
    return text


def describe(name: str) -> list[str]:
    """The lines of ``study info NAME``."""
    study = registry.get(name)
    workers = os.cpu_count() or 1
    lines = [f"{study.name}: {study.title}"]
    about = summary(study)
    if about:
        lines.append(f"  {about}")
    lines.append("variables: " + ", ".join(f"{v.name} [{v.units}]" for v in study.variables))
    lines.append("settings (default, --quick, units; change with --set KEY=VALUE):")
    lines += settings_lines(study)
    sweepable = ", ".join(study.sweepable) or "none"
    lines.append(f"sweepable (--set KEY=a,b,c or KEY=start:stop:num makes an axis): {sweepable}; "
                 "a grid axis takes a list or range too (new grid values)")
    for quick in (False, True):
        dims, points, chunks = _grid(study, quick)
        label = "grid with --quick" if quick else "grid"
        lines.append(f"{label}: {dims} = {points} points in {chunks} chunks; "
                     f"run time on {workers} cores: {estimate(study, points, min(workers, chunks), quick)}")
    lines.append(f"run: study run {study.name} [--quick] [--set KEY=VALUE ...] [--out DIR]; "
                 "output: <out>/" + study.name + ".nc and .png")
    return lines
