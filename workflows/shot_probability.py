"""The make-probability of a release under a shooter's release spread, and what it is sensitive to.

- ``shot-probability``: over a grid of nominal releases (speed [m/s] x elevation angle [degree], at a
  given distance, height and backspin), the probability that a shot released with Gaussian noise
  around the nominal release goes in, with its Wilson interval, split into swish / rim / roll / board
  makes (``solver.shots.OUTCOME_MEANINGS``: swish, make_rim, make_roll, make_board). The noise: speed
  SD ``sd_speed`` [m/s], angle SD ``sd_angle`` [degree] (defaults 0.08 m/s and 1.3 degree: the
  measured spreads of Slegers, Lee and Wong, J. Sports Sci. Med. 20 (2021) 508, speed SD 0.05-0.13
  m/s), backspin SD ``sd_backspin`` [1/s] and a sideways aim SD ``sd_azimuth`` [degree] (assumed:
  no measured source; both settings). Every nominal release sees the **same** draws (common random
  numbers, ``solver.analysis.predictability.noise_draws`` of ``seed``, the machinery of the rim's
  ``make-probability``), so the map is smooth and a rerun is bit for bit the same; the Wilson
  interval is ``predictability.wilson_interval``. ``makes = swish_only`` counts every shot that
  touches the rim or the board as a miss (the clean window alone). Derived over the grid: the best
  release of each spread (the grid point of the largest make-probability).
- ``shot-sensitivity``: the make-probability of one release (by default the best free throw of the
  ``shot-probability`` default run) for each of a list of cases, each one unknown of the model moved
  (the restitution e and friction mu of the rim, the capture speed v_cap, drag on, drag with
  the Magnus lift on, the rim phase's dissipation), so that a reader sees which unknown matters most.

The shots are ``solver.shots.simulate_shots`` (docs/shots.md); nothing here changes the shot.
"""

from __future__ import annotations

import math

import numpy as np
from matplotlib.figure import Figure

from rimroll.solver import shots
from rimroll.solver.analysis import predictability as pred
from rimroll.study.dataset import setting_of
from rimroll.study.registry import Axis, ReferenceSpec, Study, Var, register

# ================================================================ settings
RELEASE_SETTINGS = {  # the release but its speed and angle: the solver's defaults, 3 Hz backspin
    key: (math.degrees(item.default) if key == "azimuth" else item.default)
    for key, item in shots.RELEASE.items() if item.default is not None}
RELEASE_SETTINGS["backspin"] = round(2 * math.pi * 3.0, 4)  # [1/s] 3 Hz: Tran and Silverberg's free throw
CONTACT_SETTINGS = dict(shots.Contact()._asdict())  # e_rim, mu_rim, e_board, mu_board, v_cap: the solver's
NOISE = {"sd_speed": 0.08,  # [m/s] Slegers et al. (2021): 0.05-0.13 m/s
         "sd_angle": 1.3,  # [degree] Slegers et al. (2021)
         "sd_backspin": 3.0,  # [1/s] assumed (about 0.5 Hz)
         "sd_azimuth": 0.5}  # [degree] assumed: 3.7 cm sideways at a free throw's 4.19 m
"""The release spread: standard deviations of the Gaussian noise about the nominal release."""
GRID = {"speed_min": 6.8, "speed_max": 7.7, "n_speed": 19,  # [m/s]
        "angle_min": 44.0, "angle_max": 62.0, "n_angle": 19}  # [degree]
SETTINGS = {**GRID, **RELEASE_SETTINGS, **CONTACT_SETTINGS, **NOISE,
            "draws": 1000, "seed": 0, "confidence": 0.95, "makes": "all",
            "geometry": "paper", "t_max_shot": 5.0, "max_impacts": 100}
QUICK = {"n_speed": 7, "n_angle": 6, "draws": 200}
SWEEPABLE = ("sd_speed", "sd_angle", "backspin", "distance", "height", *CONTACT_SETTINGS)
RING_IGNORES = {k: "the ring is the geometry setting's (paper: Table 1; regulation: FIBA)" for k in ("R", "a")}

MAKES = {"swish": ("swish",), "rim": ("make_rim",), "roll": ("make_roll",), "board": ("make_board",)}
"""The kinds of make (variable suffix -> outcome names of ``shots.OUTCOME_MEANINGS``)."""
MAKE_NAMES = tuple(name for names in MAKES.values() for name in names)


def outcome_index(name: str) -> int:
    """The code of an outcome name in ``shots.OUTCOME_MEANINGS``."""
    return list(shots.OUTCOME_MEANINGS).index(name)


def check_noise(s: dict) -> None:
    """ValueError naming the first spread or count of ``s`` that is not allowed."""
    for key in NOISE:
        values = s[key] if isinstance(s[key], tuple) else (s[key],)
        if not all(np.isfinite(v) and v >= 0 for v in values):
            raise ValueError(f"{key} must be a finite standard deviation >= 0; got {s[key]!r}")
    if not int(s["draws"]) >= 1:
        raise ValueError(f"draws must be >= 1; got {s['draws']!r}")
    if not 0 < float(s["confidence"]) < 1:
        raise ValueError(f"confidence must lie in (0, 1); got {s['confidence']!r}")


def noisy_releases(s: dict, speed, angle_deg) -> dict:
    """The release dict of ``shots.simulate_shots`` for every nominal (speed [m/s], angle [degree]) and
    draw: arrays of shape speed.shape + (draws,). Draw i is the nominal release plus
    (sd_speed, sd_angle, sd_backspin, sd_azimuth) * z_i, z_i = ``predictability.noise_draws(draws,
    seed)[i]``, the same for every nominal release (common random numbers)."""
    z = pred.noise_draws(int(s["draws"]), int(s["seed"]))
    v = np.asarray(speed, float)[..., None] + float(s["sd_speed"]) * z[:, 0]
    theta = np.radians(np.asarray(angle_deg, float)[..., None] + float(s["sd_angle"]) * z[:, 1])
    spin = float(s["backspin"]) + float(s["sd_backspin"]) * z[:, 2]
    azimuth = np.radians(float(s["azimuth"]) + float(s["sd_azimuth"]) * z[:, 3])
    return {"speed": np.maximum(v, 1e-3), "angle": np.clip(theta, -np.pi / 2, np.pi / 2),
            "distance": float(s["distance"]), "height": float(s["height"]), "lateral": float(s["lateral"]),
            "azimuth": azimuth, "backspin": spin, "sidespin": float(s["sidespin"])}


def contact_of(s: dict) -> shots.Contact:
    """The contact coefficients of the settings."""
    return shots.Contact(**{k: float(s[k]) for k in CONTACT_SETTINGS})


def rim_params(p, geometry: str):
    """The run's Params with the ring (R, a) of ``geometry`` (``shots.params_for``)."""
    return shots.params_for(geometry, **p.as_dict())


def make_counts(outcome, makes: str = "all") -> dict:
    """Counts over the last axis of shot outcome codes: ``make`` and each kind of make of :data:`MAKES`,
    plus ``unfinished``. ``makes = swish_only``: a make after any contact counts as a miss."""
    o = np.asarray(outcome)
    if makes not in ("all", "swish_only"):
        raise ValueError(f"makes must be 'all' or 'swish_only'; got {makes!r}")
    out = {}
    for kind, names in MAKES.items():
        hit = np.isin(o, [outcome_index(n) for n in names])
        out[kind] = (hit if (makes == "all" or kind == "swish") else np.zeros_like(hit)).sum(axis=-1)
    out["make"] = sum(out[k] for k in MAKES)
    out["unfinished"] = (o == outcome_index("unfinished")).sum(axis=-1)
    return out


def probability_fields(counts: dict, n: int, confidence: float) -> dict:
    """p_KIND and its Wilson interval p_KIND_lower/upper (``predictability.wilson_interval``) of every
    kind of ``make_counts`` but ``unfinished``; n draws per estimate."""
    out = {}
    for kind in ("make", *MAKES):
        low, high = pred.wilson_interval(counts[kind], n, confidence)
        out[f"p_{kind}"], out[f"p_{kind}_lower"], out[f"p_{kind}_upper"] = counts[kind] / n, low, high
    return out


def simulate_noisy(s: dict, p, speed, angle_deg) -> dict:
    """The outcome codes (..., draws) of the noisy shots about each nominal release."""
    geometry = str(s["geometry"])
    res = shots.simulate_shots(noisy_releases(s, speed, angle_deg), rim_params(p, geometry), contact_of(s),
                               geometry=geometry, t_max=float(s["t_max_shot"]), max_impacts=int(s["max_impacts"]),
                               lift=bool(s.get("lift", False)))
    return res["outcome"]


def _nominal(s: dict, p, speed, angle_deg):
    nominal = {"speed": np.asarray(speed, float), "angle": np.radians(angle_deg), "distance": float(s["distance"]),
               "height": float(s["height"]), "lateral": float(s["lateral"]),
               "azimuth": math.radians(float(s["azimuth"])), "backspin": float(s["backspin"]),
               "sidespin": float(s["sidespin"])}
    geometry = str(s["geometry"])
    return shots.simulate_shots(nominal, rim_params(p, geometry), contact_of(s), geometry=geometry,
                                t_max=float(s["t_max_shot"]), max_impacts=int(s["max_impacts"]))["outcome"]


def _compute(coords, p, s: dict) -> dict:
    check_noise(s)
    speed, angle = coords
    counts = make_counts(simulate_noisy(s, p, speed, angle), str(s["makes"]))
    out = probability_fields(counts, int(s["draws"]), float(s["confidence"]))
    out["n_unfinished"] = counts["unfinished"]
    out["outcome"] = _nominal(s, p, speed, angle)
    return out


def _axes(s: dict) -> list:
    check_noise(s)
    return [Axis("speed", np.linspace(s["speed_min"], s["speed_max"], int(s["n_speed"])), "m s-1",
                 "nominal release speed", comment="speed of the ball's centre at the release, before the noise"),
            Axis("angle", np.linspace(s["angle_min"], s["angle_max"], int(s["n_angle"])), "degree",
                 "nominal release angle", comment="elevation of the release velocity, before the noise")]


def _flags(meanings) -> tuple:
    return tuple(range(len(meanings))), " ".join(meanings)


OUTCOME_FLAGS = _flags(shots.OUTCOME_MEANINGS)
KIND_TEXT = {"make": "a make of any kind", "swish": "a swish (no contact)",
             "rim": "a make after rim contact (make_rim)", "roll": "a make after rolling on the rim (make_roll)",
             "board": "a make off the board (make_board)"}


def _variables() -> list:
    out = [Var("outcome", "1", "outcome of the nominal release (no noise)", dtype="int8",
               flag_values=OUTCOME_FLAGS[0], flag_meanings=OUTCOME_FLAGS[1])]
    for kind, text in KIND_TEXT.items():
        out += [Var(f"p_{kind}", "1", f"probability of {text} under the release noise",
                    comment="Monte Carlo over draws noisy releases, the same draws for every nominal release "
                            "(common random numbers); makes = swish_only: a shot that touches the rim or the board "
                            "counts as a miss"),
                Var(f"p_{kind}_lower", "1", f"lower end of the Wilson interval of p_{kind}"),
                Var(f"p_{kind}_upper", "1", f"upper end of the Wilson interval of p_{kind}")]
    out.append(Var("n_unfinished", "1", "noisy shots a budget ended (counted as misses)", dtype="int32"))
    return out


VARIABLES = _variables()


def best_release(ds) -> dict:
    """The grid point of the largest p_make for every point of the swept axes: its nominal speed, angle,
    p_make and Wilson interval (the first of equal maxima; the maximum of noisy estimates is biased up by
    about their spread)."""
    p = ds["p_make"]
    lead = [d for d in p.dims if d not in ("speed", "angle")]
    p = p.transpose(*lead, "speed", "angle")
    flat = p.values.reshape(p.shape[:len(lead)] + (-1,))
    k = np.argmax(flat, axis=-1)
    i, j = np.unravel_index(k, p.shape[len(lead):])
    pick = lambda name: np.take_along_axis(  # noqa: E731
        ds[name].transpose(*lead, "speed", "angle").values.reshape(flat.shape), k[..., None], axis=-1)[..., 0]
    lead = tuple(lead)
    return {"best_speed": (lead, ds["speed"].values[i], {"units": "m s-1", "long_name": "nominal release speed of "
                                                         "the largest make-probability"}),
            "best_angle": (lead, ds["angle"].values[j], {"units": "degree", "long_name": "nominal release angle of "
                                                         "the largest make-probability"}),
            "best_p_make": (lead, pick("p_make"), {"units": "1", "long_name": "largest make-probability on the grid"}),
            "best_p_make_lower": (lead, pick("p_make_lower"), {"units": "1", "long_name": "lower end of its Wilson "
                                                               "interval"}),
            "best_p_make_upper": (lead, pick("p_make_upper"), {"units": "1", "long_name": "upper end of its Wilson "
                                                               "interval"})}


def _plane(ds):
    extra = [d for d in ds["p_make"].dims if d not in ("speed", "angle")]
    sel = ds.isel({d: 0 for d in extra})
    return sel, ", ".join(f"{d} = {float(ds[d].values[0]):g}" for d in extra)


def _plot(ds) -> Figure:
    sel, note = _plane(ds)
    speed, angle = ds["speed"].values, ds["angle"].values
    fig = Figure(figsize=(15.0, 4.6), layout="constrained")
    axes = fig.subplots(1, 4, sharey=True)
    for ax, kind in zip(axes, ("make", "swish", "rim", "roll")):
        mesh = ax.pcolormesh(speed, angle, sel[f"p_{kind}"].transpose("angle", "speed").values, cmap="viridis",
                             vmin=0, vmax=max(0.05, float(sel["p_make"].max())), shading="nearest", rasterized=True)
        ax.set_title(f"P({kind})" if kind != "make" else "P(make): every kind", fontsize=10)
        ax.set_xlabel("nominal release speed [m/s]")
    fig.colorbar(mesh, ax=axes, label="probability [-]", shrink=0.9)
    axes[0].set_ylabel("nominal release angle [degree]")
    b_speed, b_angle = float(sel["best_speed"]), float(sel["best_angle"])
    axes[0].plot([b_speed], [b_angle], "r*", ms=12)
    spread = ", ".join(f"{k} {float(setting_of(sel, k)):g}" for k in NOISE)
    fig.suptitle(f"make-probability under release noise ({spread}; {int(setting_of(sel, 'draws'))} draws, "
                 f"makes = {setting_of(sel, 'makes')}); best (red star): {b_speed:.3g} m/s, {b_angle:.3g} deg, "
                 f"P = {float(sel['best_p_make']):.3f}" + (f"\n({note})" if note else ""), fontsize=10)
    return fig


register(Study(
    name="shot-probability",
    title="Make-probability of a release under Gaussian release noise (swish, rim, roll and board makes)",
    settings=SETTINGS, quick=QUICK, axes=_axes, variables=VARIABLES, compute=_compute, plot=_plot,
    chunks={"speed": 1}, sweepable=SWEEPABLE, derive=best_release, ignores=RING_IGNORES, compiles=True,
    cost=0.12, cost_scale="draws",
    derived_docs=((("best_speed", "best_angle"), "m s-1, degree", "the nominal release of the largest make-probability "
                   "(per point of the swept axes)"),
                  (("best_p_make", "best_p_make_lower", "best_p_make_upper"), "1",
                   "that make-probability and its Wilson interval")),
    reference=ReferenceSpec(points={"speed": 5, "angle": 5}, method="solver.shots.simulate_shots with seeded "
                            "draws (a regression reference at the study's own settings)"),
))


# ================================================================ sensitivity
CASES = {  # label -> (what moves, changes of the settings, changes of the Params)
    "base": ("the defaults (e_rim 0.6, mu_rim 0.5, v_cap 0.14 m/s, vacuum, no rim resistance)", {}, {}),
    "e_rim_low": ("e_rim = 0.5", {"e_rim": 0.5}, {}),
    "e_rim_high": ("e_rim = 0.8", {"e_rim": 0.8}, {}),
    "mu_rim_low": ("mu_rim = 0.3", {"mu_rim": 0.3}, {}),
    "mu_rim_high": ("mu_rim = 1", {"mu_rim": 1.0}, {}),
    "v_cap_low": ("v_cap halved", {"v_cap": CONTACT_SETTINGS["v_cap"] / 2}, {}),
    "v_cap_high": ("v_cap doubled", {"v_cap": CONTACT_SETTINGS["v_cap"] * 2}, {}),
    "mu_roll_low": ("friction of the rolling phase mu = 0.5 (Params.mu)", {}, {"mu": 0.5}),
    "drag": ("air drag, rho_air = 1.2 kg/m^3, C_D = 0.5 (no Magnus lift)", {}, {"rho_air": 1.2}),
    "drag_magnus": ("air drag and the Magnus lift (shots.simulate_shots lift=True), rho_air = 1.2 kg/m^3",
                    {"lift": True}, {"rho_air": 1.2}),
    "rolling_resistance": ("rolling resistance k_r = 0.02 1/s on the rim (83)", {}, {"k_r": 0.02}),
    "drilling_resistance": ("drilling resistance k_d = 0.02 1/s on the rim (83)", {}, {"k_d": 0.02}),
    "regulation_ring": ("the FIBA ring (R = 0.234 m, a = 0.009 m) for the paper's", {"geometry": "regulation"}, {}),
}
"""The cases of ``shot-sensitivity``: one unknown of the model moved from the base each (``drag_magnus``:
the lift on top of ``drag``, as the lift needs air). A case's setting ``lift`` is the ``lift`` keyword of
``shots.simulate_shots``, no study setting."""
SENS_SETTINGS = {**SETTINGS, "speed": 7.2, "angle": 55.0, "draws": 2000}  # the best free throw of shot-probability
for _key in GRID:
    del SENS_SETTINGS[_key]
SENS_QUICK = {"draws": 200}


def case_inputs(case: str, s: dict, p):
    """(settings, Params) of a sensitivity case: the run's, with the case's changes."""
    _, settings, physical = CASES[case]
    return {**s, **settings}, type(p)(**{**p.as_dict(), **physical})


def _sens_compute(coords, p, s: dict) -> dict:
    check_noise(s)
    (cases,) = coords
    out = {name: np.empty(cases.shape) for name in ("p_make", "p_make_lower", "p_make_upper", "p_make_aimed",
                                                    "p_make_aimed_lower", "p_make_aimed_upper", "speed_aimed")}
    base_reach = float(shots.speed_to_reach(math.radians(float(s["angle"])), float(s["distance"]),
                                            float(s["height"]), rim_params(p, str(s["geometry"]))))
    for i, case in enumerate(cases):
        cs, cp = case_inputs(str(case), s, p)
        reach = float(shots.speed_to_reach(math.radians(float(cs["angle"])), float(cs["distance"]),
                                           float(cs["height"]), rim_params(cp, str(cs["geometry"]))))
        aimed = float(s["speed"]) + reach - base_reach
        n, conf = int(cs["draws"]), float(cs["confidence"])
        for suffix, speed in (("", float(s["speed"])), ("_aimed", aimed)):
            counts = make_counts(simulate_noisy(cs, cp, np.array(speed), np.array(float(cs["angle"]))), cs["makes"])
            f = probability_fields(counts, n, conf)
            out[f"p_make{suffix}"][i] = f["p_make"]
            out[f"p_make{suffix}_lower"][i], out[f"p_make{suffix}_upper"][i] = f["p_make_lower"], f["p_make_upper"]
        out["speed_aimed"][i] = aimed
    return out


def _sens_axes(s: dict) -> list:
    check_noise(s)
    return [Axis("case", np.array(list(CASES)), "1", "model case",
                 comment="; ".join(f"{k}: {v[0]}" for k, v in CASES.items()))]


SENS_VARIABLES = [
    Var("p_make", "1", "make-probability of the release under the release noise",
        comment="the same nominal release in every case"),
    Var("p_make_lower", "1", "lower end of the Wilson interval of p_make"),
    Var("p_make_upper", "1", "upper end of the Wilson interval of p_make"),
    Var("p_make_aimed", "1", "make-probability of the release re-aimed for the case",
        comment="nominal speed moved by the change of the speed through the hoop's centre (shots.speed_to_reach): "
                "the shooter's correction for drag or another ring (speed_to_reach has no lift: drag_magnus is "
                "re-aimed as drag is)"),
    Var("p_make_aimed_lower", "1", "lower end of the Wilson interval of p_make_aimed"),
    Var("p_make_aimed_upper", "1", "upper end of the Wilson interval of p_make_aimed"),
    Var("speed_aimed", "m s-1", "nominal speed of the re-aimed release"),
]


def _sens_plot(ds) -> Figure:
    cases = [str(c) for c in ds["case"].values]
    fig = Figure(figsize=(9.0, 5.0), layout="constrained")
    ax = fig.subplots()
    y = np.arange(len(cases))
    for off, name, colour in ((-0.17, "p_make", "C0"), (0.17, "p_make_aimed", "C1")):
        p = ds[name].values
        err = np.stack([p - ds[f"{name}_lower"].values, ds[f"{name}_upper"].values - p])
        ax.errorbar(p, y + off, xerr=err, fmt="o", color=colour, capsize=3,
                    label="same release" if name == "p_make" else "re-aimed release")
    ax.axvline(float(ds["p_make"].values[cases.index("base")]) if "base" in cases else np.nan, color="0.5", ls=":")
    ax.set_yticks(y, cases)
    ax.invert_yaxis()
    ax.set_xlabel("make-probability [-] (Wilson interval)")
    ax.legend(fontsize=8)
    ax.set_title(f"sensitivity of the make-probability of {float(setting_of(ds, 'speed')):g} m/s, "
                 f"{float(setting_of(ds, 'angle')):g} deg ({int(setting_of(ds, 'draws'))} draws per case)",
                 fontsize=10)
    return fig


register(Study(
    name="shot-sensitivity",
    title="Sensitivity of a release's make-probability to e, mu, v_cap, drag, Magnus, the ring, the rim's dissipation",
    settings=SENS_SETTINGS, quick=SENS_QUICK, axes=_sens_axes, variables=SENS_VARIABLES, compute=_sens_compute,
    plot=_sens_plot, chunks={"case": 1}, ignores=RING_IGNORES, compiles=True, cost=1.0, cost_scale="draws",
    reference=ReferenceSpec(points={}, method="solver.shots.simulate_shots with seeded draws (a regression "
                            "reference at the study's own settings)"),
))
