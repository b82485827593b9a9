"""The ``shot`` study: the classic success map of a shot, release speed x elevation angle.

Every grid point is one shot of ``solver.shots.simulate_shots`` (docs/shots.md): released at a
given distance from the hoop's axis and height below the rim plane, with backspin and sidespin,
through free flight (air drag when rho_air > 0), impacts with the rim and the board (restitution
and Coulomb friction), capture onto the rim and the engine's rolling, to a make, a miss or a
budget. The grid is ``speed`` [m/s] x ``angle`` [degree]; the release, the contact coefficients
and the ring (``geometry``) are settings, and the backspin, the distance, the height, e, mu,
v_cap and the ring may be swept (``--set backspin=0,10,20``, ``--set geometry=paper,regulation``: a label
axis). Every output of the solver is a variable of the
file; the figure shows the outcome map (swish, makes after the rim, the board or rolling, the
misses) with the speed that reaches the hoop's centre.
"""

from __future__ import annotations

import math

import numpy as np
from matplotlib.figure import Figure
from matplotlib.lines import Line2D
from matplotlib.patches import Patch

from rimroll import solver
from rimroll.solver import shots
from rimroll.study.dataset import params_of, setting_of
from rimroll.study.registry import Axis, ReferenceSpec, Study, Var, register

RELEASE_SETTINGS = {  # the release but its speed and angle (the grid), defaults of shots.RELEASE
    key: (math.degrees(item.default) if key == "azimuth" else item.default)
    for key, item in shots.RELEASE.items() if item.default is not None}
"""distance [m] (4.19: a free throw), height [m] (0.92), lateral [m], azimuth [degree], backspin and sidespin
[1/s]."""
CONTACT_SETTINGS = dict(shots.Contact()._asdict())  # e_rim, mu_rim, e_board, mu_board, v_cap: the solver's defaults
GRID = {"speed_min": 6.5, "speed_max": 7.9, "n_speed": 200,  # [m/s]
        "angle_min": 40.0, "angle_max": 65.0, "n_angle": 200}  # [degree]
SETTINGS = {**GRID, **RELEASE_SETTINGS, **CONTACT_SETTINGS,
            "geometry": "paper", "t_max_shot": 5.0, "max_impacts": 100}
QUICK = {"n_speed": 24, "n_angle": 20}
SWEEPABLE = ("backspin", "distance", "height", *CONTACT_SETTINGS, "geometry")
RING_IGNORES = {k: "the ring is the geometry setting's (paper: Table 1; regulation: FIBA), recorded as the "
                   "variables ring_R and ring_a" for k in ("R", "a")}


def _flags(meanings) -> tuple[tuple, str]:
    names = list(meanings)
    return tuple(range(len(names))), " ".join(names)


OUTCOME_FLAGS = _flags(shots.OUTCOME_MEANINGS)
STATUS_FLAGS = _flags(shots.STATUS_MEANINGS)
FIRST_FLAGS = _flags(shots.FIRST_CONTACT_MEANINGS)
RIM_FLAGS = ((-1, *solver.OUTCOME_MEANINGS),
             " ".join(["never_captured", *(m.split(":")[0] for m in solver.OUTCOME_MEANINGS.values())]))

VARIABLES = [
    Var("outcome", "1", "outcome of the shot", dtype="int8", flag_values=OUTCOME_FLAGS[0],
        flag_meanings=OUTCOME_FLAGS[1], comment="make: the centre passes below the rim plane inside the ring "
        "(swish: with no contact; make_rim, make_board: after impacts; make_roll: after rolling on the rim); "
        "miss_*: outside it; unfinished: a budget ended the shot (see status)"),
    Var("status", "1", "how the simulation of the shot ended", dtype="int8", flag_values=STATUS_FLAGS[0],
        flag_meanings=STATUS_FLAGS[1], standard_name="status_flag"),
    Var("n_impacts", "1", "impacts with the rim and the board", dtype="int32"),
    Var("n_rim_impacts", "1", "impacts with the rim", dtype="int32"),
    Var("n_board_impacts", "1", "impacts with the board", dtype="int32"),
    Var("n_double_contacts", "1", "impacts on rim and board at once", dtype="int32",
        comment="the ball touched the rim and the board within the solver's double-contact time (docs/shots.md)"),
    Var("t_end", "s", "time from the release to the end of the shot"),
    Var("time_on_rim", "s", "time rolling or slipping on the rim"),
    Var("revolutions_on_rim", "1", "revolutions around the rim's axis while on the rim"),
    Var("beta_cap", "rad", "beta when captured onto the rim", comment="NaN: never captured (paper Fig. 2)"),
    Var("omega1_cap", "s-1", "omega1 when captured onto the rim", comment="NaN: never captured"),
    Var("omega2_cap", "s-1", "omega2 when captured onto the rim", comment="NaN: never captured"),
    Var("omega3_cap", "s-1", "omega3 when captured onto the rim", comment="NaN: never captured"),
    Var("slip_cap", "m s-1", "slip speed when captured onto the rim", comment="NaN: never captured"),
    Var("first_contact", "1", "what the ball touched first", dtype="int8", flag_values=FIRST_FLAGS[0],
        flag_meanings=FIRST_FLAGS[1]),
    Var("rim_outcome", "1", "rim engine's outcome of the last capture", dtype="int8", flag_values=RIM_FLAGS[0],
        flag_meanings=RIM_FLAGS[1], comment="the outcome codes of solver.simulate (docs/outcome-studies.md) for the "
        "ball's last stay on the rim; never_captured: no stay"),
    Var("impact_kinds", "1", "kinds of the first 20 impacts", comment="base-3 digits, the first impact the lowest: "
        "1 rim, 2 board (0: no more impacts); e.g. 7 = 1 + 2*3: the rim, then the board. Stored as float64 (exact: "
        "3^20 < 2^53; CF-1.8 has no 64-bit integers)"),
]
"""Every per-shot output of ``shots.simulate_shots``, in file order."""


def release_of(s: dict, speed, angle_deg) -> dict:
    """The release dict of ``shots.simulate_shots`` from the settings (SI; angles from degrees to rad)."""
    return {"speed": np.asarray(speed, float), "angle": np.radians(angle_deg), "distance": float(s["distance"]),
            "height": float(s["height"]), "lateral": float(s["lateral"]),
            "azimuth": np.radians(float(s["azimuth"])), "backspin": float(s["backspin"]),
            "sidespin": float(s["sidespin"])}


def contact_of(s: dict) -> shots.Contact:
    """The contact coefficients of the settings."""
    return shots.Contact(**{k: float(s[k]) for k in CONTACT_SETTINGS})


def rim_params(p, geometry: str):
    """The run's Params with the ring (R, a) of ``geometry`` (``shots.params_for``)."""
    return shots.params_for(geometry, **p.as_dict())


def _compute(coords, p, s: dict) -> dict:
    speed, angle = coords
    res = shots.simulate_shots(release_of(s, speed, angle), rim_params(p, s["geometry"]), contact_of(s),
                               geometry=s["geometry"], t_max=float(s["t_max_shot"]), max_impacts=int(s["max_impacts"]))
    return {v.name: np.asarray(res[v.name]).astype(v.dtype) for v in VARIABLES}


def _axes(s: dict) -> list:
    return [Axis("speed", np.linspace(s["speed_min"], s["speed_max"], int(s["n_speed"])), "m s-1",
                 "release speed", comment="speed of the ball's centre at the release"),
            Axis("angle", np.linspace(s["angle_min"], s["angle_max"], int(s["n_angle"])), "degree",
                 "release angle", comment="elevation of the release velocity above the horizontal")]


def _derive(ds) -> dict:
    """The ring the shots ran with (the geometry's R and a): scalars, or along ``geometry`` when it is swept."""
    swept = "geometry" in ds.dims
    names = [str(g) for g in ds["geometry"].values] if swept else [str(setting_of(ds, "geometry"))]
    rings = [shots.params_for(name) for name in names]
    dims = ("geometry",) if swept else ()

    def values(key):
        out = np.array([getattr(ring, key) for ring in rings], dtype=np.float64)
        return out if swept else out[0]

    return {"ring_R": (dims, values("R"), {"units": "m", "long_name": "major radius of the ring (torus)"}),
            "ring_a": (dims, values("a"), {"units": "m", "long_name": "minor radius of the ring (tube)"})}


# ---------------------------------------------------------------- the figure
GROUPS = (  # (label, colour, outcome names): the map's categories, in legend order
    ("swish (no contact)", "#1a9850", ("swish",)),
    ("make after rim contact", "#a6d96a", ("make_rim",)),
    ("make off the board", "#4575b4", ("make_board",)),
    ("make after rolling on the rim", "#fee08b", ("make_roll",)),
    ("airball (no contact)", "#d9d9d9", ("airball",)),
    ("miss short", "#f46d43", ("miss_short",)),
    ("miss long", "#a50026", ("miss_long",)),
    ("miss left / right", "#c2a5cf", ("miss_left", "miss_right")),
    ("miss off the board", "#762a83", ("miss_board",)),
    ("unfinished (budget)", "#404040", ("unfinished",)),
)


def group_codes(meanings=None) -> np.ndarray:
    """For each outcome code, the index of its group in :data:`GROUPS` (an unknown name: the last)."""
    names = list(meanings or shots.OUTCOME_MEANINGS)
    lookup = {name: k for k, (_, _, members) in enumerate(GROUPS) for name in members}
    return np.array([lookup.get(name, len(GROUPS) - 1) for name in names])


def _plane(ds):
    """The (speed, angle) plane to draw and a note on the point taken along swept axes."""
    extra = [d for d in ds["outcome"].dims if d not in ("speed", "angle")]
    sel = ds.isel({d: 0 for d in extra})
    note = ", ".join(f"{d} = {_first(ds[d].values)}" for d in extra)
    return sel, note


def _first(values) -> str:
    """The first value of a swept axis as the figure's note shows it: a number or a label."""
    return str(values[0]) if values.dtype.kind in "USO" else f"{float(values[0]):g}"


def _plot(ds) -> Figure:
    from matplotlib.colors import BoundaryNorm, ListedColormap

    sel, note = _plane(ds)
    speed, angle = ds["speed"].values, ds["angle"].values
    groups = group_codes(str(ds["outcome"].attrs["flag_meanings"]).split())[
        sel["outcome"].transpose("angle", "speed").values]
    fig = Figure(figsize=(8.2, 5.6), layout="constrained")
    ax = fig.subplots()
    cmap = ListedColormap([c for _, c, _ in GROUPS])
    ax.pcolormesh(speed, angle, groups, cmap=cmap, norm=BoundaryNorm(np.arange(len(GROUPS) + 1) - 0.5, len(GROUPS)),
                  shading="nearest", rasterized=True)
    p = params_of(sel)
    theta = np.radians(np.linspace(angle.min(), angle.max(), 400))
    L, h = float(setting_of(sel, "distance")), float(setting_of(sel, "height"))
    with np.errstate(invalid="ignore", divide="ignore"):
        reach = np.array([float(shots.speed_to_reach(t, L, h, p)) for t in theta])
    ax.plot(reach, np.degrees(theta), color="k", ls="--", lw=1.0)
    ax.set_xlim(speed.min(), speed.max())
    ax.set_ylim(angle.min(), angle.max())
    ax.set_xlabel("release speed [m/s]")
    ax.set_ylabel("release angle [degree]")
    title = f"shot outcomes: {L:g} m from the hoop's axis, {h:g} m below the rim"
    ax.set_title(title + (f"\n({note})" if note else ""), fontsize=10)
    present = set(np.unique(groups).tolist())
    handles = [Patch(facecolor=c, edgecolor="0.3", label=label) for k, (label, c, _) in enumerate(GROUPS)
               if k in present]
    handles.append(Line2D([], [], color="k", ls="--", lw=1.0, label="speed through the hoop's centre"))
    fig.legend(handles=handles, loc="outside right center", fontsize=8, frameon=False)
    return fig


register(Study(
    name="shot",
    title="Outcome map of a shot: release speed x angle (swish, rim makes, board makes, rolls, misses)",
    settings=SETTINGS, quick=QUICK, axes=_axes, variables=VARIABLES, compute=_compute, plot=_plot,
    chunks={"speed": 25}, sweepable=SWEEPABLE, derive=_derive, ignores=RING_IGNORES, compiles=True,
    derived_docs=(("ring_R", "m", "major radius of the ring the shots ran with (the geometry's)"),
                  ("ring_a", "m", "minor radius of the ring the shots ran with (the geometry's)")),
    reference=ReferenceSpec(points={"speed": 15, "angle": 11}, method="solver.shots.simulate_shots (event-driven; "
                            "a regression reference at the study's own settings)"),
))
