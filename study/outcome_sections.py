"""The outcome sections of Figs. 11-13, shared by the studies that run them (fig11-13,
predictability, continuation, the cubes, dissipation-models, work-precision): their default settings,
the (beta, omega1) grid, the four named scenes of ``solver.engine.scenes`` with the parameters and
t_max each runs at, and the setting ``adaptive`` that computes a section as an adaptive map
(``solver.analysis.adaptive_map``: its cost, chunks, the ``refine_level`` variable).

Not a study: it registers nothing, and the study families import it rather than each other.
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np

from rimroll import solver
from rimroll.solver.analysis import adaptive_map
from rimroll.solver.engine import scenes
from rimroll.solver.physics import switching
from rimroll.solver.physics.params import TERM_KEYS
from rimroll.study.registry import Axis

SCENES = tuple(s.name for s in scenes.NAMED)
"""Labels of the ``scene`` coordinate, in file order (the named scenes of ``solver.engine.scenes``)."""

SETTINGS = {
    "omega3": 10.0,  # [1/s]
    "beta_min": 0.8, "beta_max": 1.8, "n_beta": 240,  # [rad]
    "omega1_max": 20.0, "n_omega1": 360,  # [1/s], symmetric range
    "mu_slip": 1.0,  # friction of the slipping scenes
    "k_dissipation": 0.02,  # [1/s] rate of the drilling / rolling resistance scenes
    "t_max": 20.0,  # [s] conservative scenes
    "t_max_dissipative": 60.0,  # [s]
    "rtol": 1e-8, "atol": 1e-10, "method": "auto",
    "backend": "cpu",  # solver.simulate's backend: cpu, cuda or auto (docs/outcome-engine.md, Backends)
    "delta": switching.DELTA,  # [m/s] launch speed of a slip (Sect. 5.2.2); u_stop = delta, u_floor = delta/100
    "slip_method": "rodas4",  # solver.simulate's slip_method (docs/outcome-engine.md, "Stiff slips")
}
QUICK = {"n_beta": 24, "n_omega1": 36}
FIGURES = (("fig11", 35.0, 11), ("fig12", 65.0, 12), ("fig13", 105.0, 13))
"""The sections of the paper's Figs. 11-13: (study name, omega2 [1/s], figure number)."""


def engine_options(s) -> dict:
    """What ``solver.simulate`` takes from a study's settings (a dict, or a results file's recorded
    settings through ``get``) besides the tolerances: its ``switching`` dict with ``slip_method``,
    and where ``delta`` [m/s] is not the default, the switching tolerances it sets: the launch
    speed delta, the return threshold u_stop = delta and the floor u_floor = delta / 100 (the
    defaults' proportions, ``solver.physics.switching``). Settings a study or an older file lacks
    take their defaults."""
    options = {"slip_method": str(s.get("slip_method", "rodas4"))}
    delta = float(s.get("delta", switching.DELTA))
    if delta != switching.DELTA:
        options.update(delta=delta, u_stop=delta, u_floor=delta / 100.0)
    return {"switching": options}


def scene_table(s: dict) -> dict[str, np.ndarray]:
    """mu, k_r, k_d [1/s] and t_max [s] of the four named scenes, from the settings: mu_slip for the
    scenes that slip, k_dissipation for the parameter of each scene's term (``Scene.parameters``)."""
    rows = [scene.parameters(s["mu_slip"], s["k_dissipation"]) for scene in scenes.NAMED]
    table = {key: np.array([row[key] for row in rows]) for key in ("mu", "k_r", "k_d")}
    table["t_max"] = np.array([s["t_max"] if scene.conservative else s["t_max_dissipative"] for scene in scenes.NAMED])
    return table


def scene_axis(s: dict) -> Axis:
    """The ``scene`` axis: string labels :data:`SCENES`, with each scene's mu, k_r, k_d [1/s]
    and t_max [s] as non-index coordinates along it."""
    table = scene_table(s)
    return Axis("scene", np.array(SCENES), "", "physical scene (docs/outcome-studies.md#scenes): " + "; ".join(
        f"{scene.name} = {scene.text}" for scene in scenes.NAMED), aux={
        "mu": (table["mu"], "1", "Coulomb friction coefficient of the scene (inf: rolling only)"),
        "k_r": (table["k_r"], "s-1", "rolling-resistance rate k_r of the scene, paper (83)"),
        "k_d": (table["k_d"], "s-1", "drilling-resistance rate k_d of the scene, paper (83)"),
        "t_max": (table["t_max"], "s", "end of the run for states still on the rim"),
    })


def scene_index(label) -> int:
    """Position of a scene label in :data:`SCENES` (the row of :func:`scene_table`)."""
    return SCENES.index(str(label))


BETA_COMMENT = "initial height angle of the contact point on the rim's cross-section"
OMEGA1_COMMENT = "initial transversal angular velocity of the ball"


def section_axes(s: dict) -> list[Axis]:
    """The axes of an outcome section: the four named scenes, beta [rad] and omega1 [1/s]."""
    scene = scene_axis(s)
    beta = Axis("beta", np.linspace(s["beta_min"], s["beta_max"], int(s["n_beta"])), "rad", "initial height angle",
                comment=BETA_COMMENT)
    w = float(s["omega1_max"])
    omega1 = Axis("omega1", np.linspace(-w, w, int(s["n_omega1"])), "s-1", "initial omega1", comment=OMEGA1_COMMENT)
    return [scene, beta, omega1]


def steady_beta0(omega2: float, omega3: float, p: solver.Params, lo: float, hi: float) -> float | None:
    """beta0 in [lo, hi] [rad] of the steady motion (48) with these omega20, omega30 [1/s]; None if
    none: the star of an outcome map (it lies on omega1 = 0). The first sign change of
    omega20(beta0) - omega2 on a 400-point grid, bisected to adjacent floating-point numbers (by
    hand: importing scipy.optimize for it cost ~0.2 s of every outcome study's start)."""
    from rimroll.solver.analysis import steady

    def f(b):
        return steady.omega20(b, omega3, p) - omega2
    grid = np.linspace(lo, min(hi, np.pi / 2 - 1e-6), 400)
    vals = f(grid)
    sign = np.nonzero(np.sign(vals[:-1]) != np.sign(vals[1:]))[0]
    if not sign.size:
        return None
    a, b = float(grid[sign[0]]), float(grid[sign[0] + 1])
    fa = float(vals[sign[0]])
    if fa == 0.0:
        return a
    for _ in range(200):  # a grid spacing halves to adjacent doubles in ~60 steps
        mid = 0.5 * (a + b)
        if not a < mid < b:
            break
        f_mid = float(f(mid))
        if f_mid == 0.0:
            return mid
        if (f_mid > 0.0) == (fa > 0.0):
            a, fa = mid, f_mid
        else:
            b = mid
    return b


def scene_params(p: solver.Params, s: dict, label) -> tuple[solver.Params, float]:
    """The parameters of the named scene ``label`` (the run's physical ones with the scene's mu and
    term parameters: k_r, k_d, and 0 for every other term's) and its t_max [s], from the settings ``s``."""
    k = scene_index(label)
    scene = scenes.NAMED[k]
    t_max = s["t_max"] if scene.conservative else s["t_max_dissipative"]
    return p.replace(**scene.parameters(s["mu_slip"], s["k_dissipation"])), float(t_max)


SCENE_IGNORES = {k: "each of the four scenes sets its own mu and term parameters (k_r, k_d; the other terms off); "
                    "change mu_slip or k_dissipation" for k in ("mu", *TERM_KEYS)}
"""The physical parameters a study of the four named scenes ignores (``Study.ignores``)."""


# ================================================================ adaptive maps of a section (setting adaptive)
ADAPTIVE_SETTINGS = {"adaptive": False, "adaptive_coarse": adaptive_map.DEFAULT_COARSE}
"""The settings of a study with adaptive maps (fig11-13, outcome-cube, continuation): off by default."""
LEVEL_ATTRS = {
    "units": "1",
    "long_name": "refinement level at which this cell was simulated",
    "comment": "adaptive maps (setting adaptive = 1, docs/outcome-studies.md#adaptive-maps): k >= 0: simulated on "
               "the lattice of stride 2**k cells (0: the grid itself; the coarse level is log2(adaptive_coarse)); "
               f"{adaptive_map.FILLED}: not simulated, filled from the corners of a uniform block (categorical and "
               "integer variables from the nearest corner, floating-point ones by bilinear interpolation). Indicators "
               "of refinement besides the class (outcome, on_rim_reason, slip_phases > 0): "
               + ", ".join(f"{k}={v:g}" for k, v in adaptive_map.INDICATORS.items()) + ". A full map: 0 everywhere",
}
"""Attributes of the per-cell variable ``refine_level``."""


def _coarse(s: dict) -> int:
    return adaptive_map.check_coarse(s.get("adaptive_coarse", adaptive_map.DEFAULT_COARSE))


def adaptive_cost_factor(s: dict) -> float:
    """The cost model's multiplier of an adaptive map (``Study.cost_factor``): about 3 / adaptive_coarse of
    a full map's cost (the 12 panels at the default stride 8: 10 % of the trajectories, a third of the
    time: the cells simulated are the long ones), 1 for a full map."""
    if not s.get("adaptive"):
        return 1.0
    return min(1.0, 3.0 / _coarse(s))


def adaptive_axes(axes: Callable) -> Callable:
    """A study's ``axes(settings)`` that first checks ``adaptive_coarse`` (a ValueError there is a user error
    before any work, not a failed chunk)."""
    def checked(s: dict):
        _coarse(s)
        return axes(s)
    checked.__doc__ = axes.__doc__
    return checked


def adaptive_chunks(s: dict, full: dict) -> dict:
    """The chunks of a study: ``full`` for a full map, the whole (beta, omega1) grid for an adaptive one."""
    if s.get("adaptive"):
        return {**full, "beta": int(s["n_beta"]), "omega1": int(s["n_omega1"])}
    return full


def map_section(run: Callable, beta: np.ndarray, omega1: np.ndarray, s: dict, weight: float, keep=None) -> dict:
    """Every field of the (beta, omega1) grid of one chunk, plus ``refine_level``: every cell simulated
    (setting adaptive off, ``refine_level`` 0), or an adaptive map (``adaptive_map.section`` at the stride
    ``adaptive_coarse``).

    ``run(beta, omega1) -> {field: values}``: ``solver.simulate`` of these states (1-D arrays);
    ``beta``, ``omega1``: the chunk's coordinates broadcast to its shape; ``s``: the settings;
    ``weight``: m g [N]; ``keep``: the fields the study stores (None: all).
    """
    if not s.get("adaptive"):
        out = dict(run(beta, omega1))
        out["refine_level"] = np.zeros(beta.shape, dtype=np.int8)
        return out
    return adaptive_map.section(run, beta, omega1, int(s["adaptive_coarse"]), weight, keep=keep)
