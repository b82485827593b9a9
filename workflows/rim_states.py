"""The ``rim-states`` study: which states on the rim a real shot reaches (paper Sect. 6).

Every grid point is one shot of ``solver.shots.simulate_shots`` (docs/shots.md), released at an
elevation ``angle`` [degree] and sideways aim ``azimuth`` [degree] with a speed ``dv`` [m/s] above the
speed whose centre path passes through the hoop's centre (``shots.speed_to_reach``), so that one grid
covers a free throw and a three-pointer alike; distance, backspin and sidespin are swept by default
(free throw 4.19 m and three-pointer 6.75 m; backspin 0, 3 and 6 Hz; sidespin 0 and 2 Hz). A shot in
the vertical plane through the hoop's axis without sidespin reaches the rim with omega2 = omega3 = 0
only: the sideways aim and the sidespin are what give a captured ball its circulation. A shot whose rim
impact is soft enough is captured onto the rim: its state
(beta, omega1, omega2, omega3) [rad, 1/s] is the state the paper's rolling analysis starts from.
Beside the shot's outputs, each captured state is placed on the paper's maps:

- ``position``: the part of the rim of Fig. 8's regions by beta alone (A inside-above, 0 < beta < pi/2;
  B inside-below; C outside-above; ``solver.analysis.steady.region_of``);
- ``region``: the Fig. 8 region of the steady motion (47)-(48) at the captured (beta, omega3), where
  it is realisable (stable (54), rolling at mu (56), within the energy of a throw at ``v_throw`` (59);
  ``steady.realisable_region``), with ``omega20_cap`` the steady motion's omega2 (48) and
  ``steady_distance`` the captured state's distance from it, sqrt(omega1^2 + (omega2 - omega20)^2);
- ``rim_outcome``: the rim engine's outcome of the captured state, i.e. the outcome map of Figs.
  11-13 read at the state the shot reached (at its own omega2, omega3).

Derived over the grid (per swept point): how many shots are captured, in each position and region,
and with each rim outcome.
"""

from __future__ import annotations

import math

import numpy as np
from matplotlib.figure import Figure
from matplotlib.patches import Rectangle

from rimroll import solver
from rimroll.solver import shots
from rimroll.solver.analysis import steady
from rimroll.study.dataset import params_of, setting_of
from rimroll.study.registry import Axis, ReferenceSpec, Study, Var, register

RELEASE_SETTINGS = {key: (math.degrees(item.default) if key == "azimuth" else item.default)
                    for key, item in shots.RELEASE.items() if item.default is not None}
RELEASE_SETTINGS["distance"] = (4.19, 6.75)  # [m] a free throw, a FIBA three-pointer
RELEASE_SETTINGS["backspin"] = (0.0, round(2 * math.pi * 3, 4), round(2 * math.pi * 6, 4))  # [1/s] 0, 3, 6 Hz
RELEASE_SETTINGS["sidespin"] = (0.0, round(2 * math.pi * 2, 4))  # [1/s] 0, 2 Hz
del RELEASE_SETTINGS["azimuth"]  # an axis of the grid
CONTACT_SETTINGS = dict(shots.Contact()._asdict())
GRID = {"dv_min": -0.35, "dv_max": 0.35, "n_dv": 36,  # [m/s] about the speed through the hoop's centre
        "angle_min": 40.0, "angle_max": 64.0, "n_angle": 25,  # [degree]
        "azimuth_max": 2.5, "n_azimuth": 11}  # [degree], symmetric: the sideways aim
SETTINGS = {**GRID, **RELEASE_SETTINGS, **CONTACT_SETTINGS, "v_throw": 10.0,
            "geometry": "paper", "t_max_shot": 5.0, "max_impacts": 100}
QUICK = {"n_dv": 11, "n_angle": 7, "n_azimuth": 5}
SWEEPABLE = ("backspin", "sidespin", "distance", "height", "v_throw", *CONTACT_SETTINGS)
RING_IGNORES = {k: "the ring is the geometry setting's (paper: Table 1; regulation: FIBA)" for k in ("R", "a")}
SECTIONS = {"omega2": (35.0, 65.0, 105.0), "omega3": 10.0, "beta": (0.8, 1.8), "omega1": (-20.0, 20.0)}
"""The outcome sections of Figs. 11-13 (study.outcome_sections): omega2, omega3 [1/s] and the (beta, omega1) window."""


def _flags(meanings) -> tuple:
    return tuple(range(len(meanings))), " ".join(meanings)


OUTCOME_FLAGS = _flags(shots.OUTCOME_MEANINGS)
RIM_FLAGS = ((-1, *solver.OUTCOME_MEANINGS),
             " ".join(["never_captured", *(m.split(":")[0] for m in solver.OUTCOME_MEANINGS.values())]))
POSITION_MEANINGS = "not_captured A_inside_above B_inside_below C_outside_above"

VARIABLES = [
    Var("speed", "m s-1", "release speed", comment="the speed through the hoop's centre plus dv"),
    Var("outcome", "1", "outcome of the shot", dtype="int8", flag_values=OUTCOME_FLAGS[0],
        flag_meanings=OUTCOME_FLAGS[1]),
    Var("status", "1", "how the simulation of the shot ended", dtype="int8",
        flag_values=_flags(shots.STATUS_MEANINGS)[0], flag_meanings=_flags(shots.STATUS_MEANINGS)[1],
        standard_name="status_flag"),
    Var("n_rim_impacts", "1", "impacts with the rim", dtype="int32"),
    Var("beta_cap", "rad", "beta when captured onto the rim", comment="NaN: never captured (paper Fig. 2)"),
    Var("omega1_cap", "s-1", "omega1 when captured onto the rim", comment="NaN: never captured"),
    Var("omega2_cap", "s-1", "omega2 when captured onto the rim", comment="NaN: never captured"),
    Var("omega3_cap", "s-1", "omega3 when captured onto the rim", comment="NaN: never captured"),
    Var("slip_cap", "m s-1", "slip speed when captured onto the rim", comment="NaN: never captured; > 0: a "
        "sliding capture"),
    Var("time_on_rim", "s", "time rolling or slipping on the rim"),
    Var("rim_outcome", "1", "rim engine's outcome of the last capture", dtype="int8", flag_values=RIM_FLAGS[0],
        flag_meanings=RIM_FLAGS[1], comment="the outcome maps of Figs. 11-13 read at the captured state"),
    Var("position", "1", "part of the rim of the captured beta (Fig. 8's letters)", dtype="int8",
        flag_values=steady.REGION_FLAG_VALUES, flag_meanings=POSITION_MEANINGS,
        comment="A: 0 < beta < pi/2, B: -pi/2 < beta < 0, C: pi/2 < beta < pi (steady.region_of)"),
    Var("region", "1", "Fig. 8 region of the steady motion at the captured (beta, omega3)", dtype="int8",
        flag_values=steady.REGION_FLAG_VALUES, flag_meanings=steady.REGION_FLAG_MEANINGS,
        comment="steady.realisable_region at mu (the run's) and v_throw; not_realisable also where never captured"),
    Var("omega20_cap", "s-1", "omega2 of the steady motion (48) at the captured (beta, omega3)"),
    Var("steady_distance", "s-1", "distance of the captured state from that steady motion",
        comment="sqrt(omega1^2 + (omega2 - omega20)^2) at the captured state"),
]


def _release(s: dict, dv, angle_deg, azimuth_deg, p) -> dict:
    theta = np.radians(np.asarray(angle_deg, float))
    reach = np.vectorize(lambda t: float(shots.speed_to_reach(t, float(s["distance"]), float(s["height"]), p)))(theta)
    return {"speed": reach + np.asarray(dv, float), "angle": theta, "distance": float(s["distance"]),
            "height": float(s["height"]), "lateral": float(s["lateral"]), "azimuth": np.radians(azimuth_deg),
            "backspin": float(s["backspin"]), "sidespin": float(s["sidespin"])}


def place_on_maps(res: dict, p, v_throw: float) -> dict:
    """``position``, ``region``, ``omega20_cap`` and ``steady_distance`` of captured states (``res``: outputs
    of ``simulate_shots``); ``p``: the Params of the rim (its mu is Fig. 8's)."""
    beta, w1, w2, w3 = (np.asarray(res[k], float) for k in ("beta_cap", "omega1_cap", "omega2_cap", "omega3_cap"))
    captured = np.isfinite(beta)
    position = np.where(captured, steady.region_of(np.nan_to_num(beta)), steady.REGION_NONE).astype(np.int8)
    region = steady.realisable_region(beta, w3, p, float(v_throw))
    with np.errstate(invalid="ignore", divide="ignore"):
        w20 = steady.omega20(beta, w3, p)
        dist = np.hypot(w1, w2 - w20)
    return {"position": position, "region": region, "omega20_cap": w20, "steady_distance": dist}


def _compute(coords, p, s: dict) -> dict:
    dv, angle, azimuth = coords
    geometry = str(s["geometry"])
    rp = shots.params_for(geometry, **p.as_dict())
    release = _release(s, dv, angle, azimuth, rp)
    res = shots.simulate_shots(release, rp, shots.Contact(**{k: float(s[k]) for k in CONTACT_SETTINGS}),
                               geometry=geometry, t_max=float(s["t_max_shot"]), max_impacts=int(s["max_impacts"]))
    out = {v.name: res[v.name] for v in VARIABLES if v.name in res}
    out["speed"] = release["speed"]
    out.update(place_on_maps(res, rp, float(s["v_throw"])))
    return out


def _axes(s: dict) -> list:
    return [Axis("dv", np.linspace(s["dv_min"], s["dv_max"], int(s["n_dv"])), "m s-1",
                 "excess release speed", comment="release speed minus the speed whose centre path passes "
                 "through the hoop's centre (shots.speed_to_reach)"),
            Axis("angle", np.linspace(s["angle_min"], s["angle_max"], int(s["n_angle"])), "degree",
                 "release angle", comment="elevation of the release velocity above the horizontal"),
            Axis("azimuth", np.linspace(-s["azimuth_max"], s["azimuth_max"], int(s["n_azimuth"])), "degree",
                 "sideways aim", comment="azimuth of the throw from the line through the hoop's axis (positive "
                 "towards the shooter's left)")]


def summary(ds) -> dict:
    """Counts over the (dv, angle) grid, per point of the swept axes: shots captured, captured in each
    position and realisable region of Fig. 8, and captured with each rim outcome."""
    lead = tuple(d for d in ds["outcome"].dims if d not in ("dv", "angle", "azimuth"))

    def count(mask, name, text):
        return name, (lead, mask.sum(("dv", "angle", "azimuth")).transpose(*lead).values.astype(np.int32),
                      {"units": "1", "long_name": text})
    captured = np.isfinite(ds["beta_cap"])
    out = dict([count(captured, "n_captured", "shots captured onto the rim")])
    letters = POSITION_MEANINGS.split()
    for code in (steady.REGION_A, steady.REGION_B, steady.REGION_C):
        name = letters[code][0]
        out.update([count(ds["position"] == code, f"n_position_{name}", f"captured shots in part {name} of the rim"),
                    count(ds["region"] == code, f"n_region_{name}",
                          f"captured shots whose steady motion is realisable in region {name} (Fig. 8)")])
    for code, meaning in solver.OUTCOME_MEANINGS.items():
        name = meaning.split(":")[0]
        out.update([count(ds["rim_outcome"] == code, f"n_rim_{name}", f"captured shots whose rim outcome is {name}")])
    return out


def _section_map(p, beta, w3, v_throw):
    return steady.realisable_region(beta, w3, p, v_throw)


def _plot(ds) -> Figure:
    extra = [d for d in ds["outcome"].dims if d not in ("dv", "angle", "azimuth")]
    p = shots.params_for(str(setting_of(ds, "geometry")), **params_of(ds.isel({d: 0 for d in extra})).as_dict())
    v_throw = float(ds["v_throw"].values.max()) if "v_throw" in extra else float(setting_of(ds, "v_throw"))
    fig = Figure(figsize=(15.5, 4.9), layout="constrained")
    ax1, ax2, ax3 = fig.subplots(1, 3)
    beta, w1, w2, w3 = (ds[k].values.ravel() for k in ("beta_cap", "omega1_cap", "omega2_cap", "omega3_cap"))
    rim = ds["rim_outcome"].values.ravel()
    ok = np.isfinite(beta)
    colours = {0: "#1a9850", 1: "#d73027", 2: "#fee08b", 3: "#4575b4", 4: "#762a83"}
    for code, meaning in solver.OUTCOME_MEANINGS.items():
        m = ok & (rim == code)
        if m.any():
            ax1.scatter(w1[m], beta[m], s=5, color=colours.get(code, "k"), label=f"{meaning.split(':')[0]} ({m.sum()})")
    b0, b1 = SECTIONS["beta"]
    o0, o1 = SECTIONS["omega1"]
    ax1.add_patch(Rectangle((o0, b0), o1 - o0, b1 - b0, fill=False, ec="k", ls="--", lw=1.0,
                            label="window of Figs. 11-13"))
    ax1.set_xlabel(r"captured $\omega_1$ [1/s]")
    ax1.set_ylabel(r"captured $\beta$ [rad]")
    ax1.set_title("captured states, coloured by their rim outcome\n(the maps of Figs. 11-13 read there)", fontsize=9)
    ax1.legend(fontsize=7, loc="best")
    ax2.scatter(w2[ok], w3[ok], s=5, c=beta[ok], cmap="viridis")
    for om in SECTIONS["omega2"]:
        ax2.plot([om], [SECTIONS["omega3"]], "r*", ms=12)
    ax2.set_xlabel(r"captured $\omega_2$ [1/s]")
    ax2.set_ylabel(r"captured $\omega_3$ [1/s]")
    ax2.set_title(r"their $(\omega_2, \omega_3)$; red stars: the sections of Figs. 11-13", fontsize=9)
    bb = np.linspace(-np.pi / 2, np.pi, 361)
    ww = np.linspace(-60.0, 60.0, 241)
    B, W = np.meshgrid(bb, ww, indexing="ij")
    region = _section_map(p, B, W, v_throw)
    ax3.contourf(W, B, region, levels=[0.5, 1.5, 2.5, 3.5], colors=["#c7e9c0", "#fdd0a2", "#dadaeb"], alpha=0.9)
    for code, y in ((1, 0.8), (2, -0.8), (3, 2.4)):
        ax3.text(50, y, "ABC"[code - 1], fontsize=14, ha="center")
    ax3.scatter(w3[ok], beta[ok], s=5, c="k")
    ax3.set_xlabel(r"$\omega_3$ [1/s]")
    ax3.set_ylabel(r"$\beta$ [rad]")
    ax3.set_title(r"captured $(\beta, \omega_3)$ over Fig. 8's realisable regions" "\n"  # two lines: one was cut off
                  rf"($v_\mathrm{{throw}}$ = {v_throw:g} m/s, $\mu$ = {p.mu:g})", fontsize=9)
    n = int(ok.sum())
    fig.suptitle(f"rim states a shot reaches: {n} of {beta.size} shots captured "
                 f"({', '.join(extra) or 'one release set'} pooled)", fontsize=10)
    return fig


register(Study(
    name="rim-states",
    title="The rim states a real shot reaches: captured (beta, omega1, omega2, omega3) over the paper's maps",
    settings=SETTINGS, quick=QUICK, axes=_axes, variables=VARIABLES, compute=_compute, plot=_plot,
    chunks={"dv": 4}, sweepable=SWEEPABLE, derive=summary, ignores=RING_IGNORES, compiles=True, cost=1e-3,
    derived_docs=((("n_captured",), "1", "shots captured onto the rim (per point of the swept axes)"),
                  (("n_position_A", "n_position_B", "n_position_C"), "1", "captured shots in each part of the rim"),
                  (("n_region_A", "n_region_B", "n_region_C"), "1", "captured shots whose steady motion is "
                   "realisable in region A, B, C of Fig. 8"),
                  (tuple(f"n_rim_{m.split(':')[0]}" for m in solver.OUTCOME_MEANINGS.values()), "1",
                   "captured shots with each rim outcome")),
    reference=ReferenceSpec(points={"dv": 4, "angle": 4, "azimuth": 3},
                            method="solver.shots.simulate_shots (event-driven; a regression reference at the study's "
                                   "own settings)"),
))
