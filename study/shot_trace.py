"""``study trace --release``: one shot's path as a netCDF time series and a figure.

The path comes from ``solver.shots.trace_shot`` (docs/shots.md): the ball centre's position over
time with the phase of each sample (flight, on the rim), and the impacts with the rim and the board.
The release is given directly (``--release speed=7.2,angle=52``, the angle in degrees, with any other
release key of the ``shot`` study: distance, height, lateral, azimuth [degree], backspin, sidespin)
and the contact, the ring and the ball with ``--set`` (``e_rim=0.5``, ``geometry=regulation``,
``rho_air=1.2``); or picked from a ``shot`` map (``FILE --at speed=7.2,angle=52``) with that file's
settings. The files are ``<out>/<name>.nc`` and ``.png``; the figure shows the path from the side
(x-z) and from above (x-y) with the ring, the board, the impacts and the rolling phase marked.
"""

from __future__ import annotations

import datetime as _dt
import pathlib

import numpy as np
import xarray as xr
from matplotlib.figure import Figure
from matplotlib.lines import Line2D
from matplotlib.patches import Circle

from rimroll.solver import Params, shots
from rimroll.study import cli_text, io
from rimroll.study.dataset import provenance, setting_of
from rimroll.study.registry import PHYSICAL_KEYS, UserError
from rimroll.study.setting_table import lookup

RELEASE_KEYS = tuple(shots.RELEASE)
DEGREES = ("angle", "azimuth")  # release keys given in degrees (rad in the solver)
RELEASE_UNITS = {k: ("degree" if k in DEGREES else item.units) for k, item in shots.RELEASE.items()}
RELEASE_DEFAULTS = {k: (np.degrees(item.default) if k in DEGREES else item.default)
                    for k, item in shots.RELEASE.items() if item.default is not None}
CONTACT_KEYS = tuple(shots.Contact._fields)
SHOT_KEYS = (*CONTACT_KEYS, "geometry", "t_max_shot", "max_impacts")
SPEED_RANGE = (shots.RELEASE["speed"].low, shots.RELEASE["speed"].high)  # [m/s] (exclusive, inclusive)
PHASE_STYLE = {0: dict(color="tab:blue", lw=1.4, label="flight"),
               1: dict(color="tab:orange", lw=2.6, label="on the rim (rolling or slipping)")}
IMPACT_STYLE = {1: dict(marker="o", mfc="tab:red", mec="k", label="impact with the rim"),
                2: dict(marker="s", mfc="tab:purple", mec="k", label="impact with the board")}


def parse_release(text: str) -> dict:
    """``--release speed=V,angle=DEG[,KEY=VALUE...]`` -> the release in the ``shot`` study's units
    (speed [m/s], angles [degree], lengths [m], spins [1/s]), defaults filled; UserError naming a bad
    key or value and what is allowed."""
    given = {}
    for key, value in cli_text.split(text, "--release", "KEY=VALUE,...", "--release speed=7.2,angle=52"):
        if key not in RELEASE_KEYS:
            raise UserError(f"--release {key}={value}: KEY must be one of {', '.join(RELEASE_KEYS)}")
        if key in given:
            raise UserError(f"--release {key} is given twice; give each release key once")
        try:
            given[key] = cli_text.number(value)
        except ValueError:
            raise UserError(f"--release {key}={value}: VALUE must be a number [{RELEASE_UNITS[key]}]") from None
    missing = [k for k in ("speed", "angle") if k not in given]
    if missing:
        raise UserError(f"--release {text!r}: give {' and '.join(missing)}, e.g. --release speed=7.2,angle=52")
    if not SPEED_RANGE[0] < given["speed"] <= SPEED_RANGE[1]:
        raise UserError(f"--release speed={given['speed']!r}: allowed {SPEED_RANGE[0]:g} < speed <= "
                        f"{SPEED_RANGE[1]:g} [m/s]")
    if not -90.0 <= given["angle"] <= 90.0:
        raise UserError(f"--release angle={given['angle']!r}: allowed -90 <= angle <= 90 [degree]")
    for key in RELEASE_DEFAULTS:
        problem = lookup(key).problem(given[key]) if key in given else None
        if problem:
            raise UserError(f"--release {key}={given[key]!r}: {problem}")
    return {**RELEASE_DEFAULTS, **given}


def parse_sets(words: list[str]) -> tuple[dict, dict]:
    """``--set KEY=VALUE`` of a shot -> (physical parameters, shot settings: contact, geometry, budgets),
    each checked by the setting table's rule of its name."""
    physical, shot = {}, {}
    for key, value in cli_text.parse(words, "--set", "KEY=VALUE", "--set e_rim=0.5"):
        if key not in PHYSICAL_KEYS and key not in SHOT_KEYS or key in ("R", "a"):
            raise UserError(f"--set {key}={value}: KEY must be one of {' '.join(SHOT_KEYS)} or of "
                            f"{' '.join(k for k in PHYSICAL_KEYS if k not in ('R', 'a'))} (the ring is the "
                            "geometry's)")
        entry = lookup(key)
        try:
            parsed = value if entry.choices is not None else cli_text.number(value)
        except ValueError:
            raise UserError(f"--set {key}={value}: VALUE must be a number") from None
        if key == "max_impacts" and float(parsed).is_integer():
            parsed = int(parsed)
        problem = entry.problem(parsed)
        if problem:
            raise UserError(f"--set {key}={value}: {problem}")
        (physical if key in PHYSICAL_KEYS else shot)[key] = parsed
    return physical, shot


def shot_settings(shot: dict) -> dict:
    """The contact, geometry and budgets of a trace: the ``shot`` study's defaults, then ``shot``."""
    from rimroll.study import registry

    defaults = {k: registry.get("shot").settings[k] for k in SHOT_KEYS}
    return {**defaults, **shot}


def from_map(path, at_text, sets: tuple[dict, dict]) -> tuple[dict, dict, dict]:
    """The release, physical parameters and shot settings of a point of a ``shot`` results file
    (``--at speed=..,angle=..``: the nearest grid point; swept settings need a value too)."""
    ds = io.open_result(path)
    if ds.attrs.get("study") != "shot":
        raise UserError(f"{path}: --release traces need a file of study shot; this one is {ds.attrs.get('study')!r}")
    at = {}
    for text in [at_text] if isinstance(at_text, str) else at_text:
        at.update(cli_text.split(text, "--at", "DIM=VALUE,...", "--at speed=7.2,angle=52"))
    point = {}
    for dim in ds["outcome"].dims:
        if dim not in at:
            raise UserError(f"{path}: --at needs a value of {dim} (e.g. {dim}={ds[dim].values[0]:g})")
        try:
            point[dim] = int(np.abs(ds[dim].values - cli_text.number(at.pop(dim))).argmin())
        except ValueError:
            raise UserError(f"--at {dim}: expected a number") from None
    if at:
        raise UserError(f"--at {', '.join(at)}: not an axis of {path} (axes: {', '.join(ds['outcome'].dims)})")
    sel = ds.isel(point)
    release = {k: float(setting_of(sel, k)) for k in RELEASE_DEFAULTS}
    release.update(speed=float(sel["speed"]), angle=float(sel["angle"]))
    physical = {k: float(setting_of(sel, k)) for k in PHYSICAL_KEYS if k not in ("R", "a")}
    shot = {k: setting_of(sel, k) for k in SHOT_KEYS}
    physical.update(sets[0])
    shot.update(sets[1])
    return release, physical, shot


def compute(release: dict, physical: dict, shot: dict) -> tuple[dict, Params]:
    """``shots.trace_shot`` of one release (degrees converted to rad) with the geometry's ring."""
    try:
        p = shots.params_for(shot["geometry"], **physical)
    except ValueError as exc:
        raise UserError(str(exc)) from None
    solver_release = {k: float(np.radians(v)) if k in DEGREES else float(v) for k, v in release.items()}
    contact = shots.Contact(**{k: float(shot[k]) for k in CONTACT_KEYS})
    res = shots.trace_shot(solver_release, p, contact, geometry=shot["geometry"])
    return res, p


def dataset(res: dict, release: dict, p: Params, shot: dict, command: str) -> xr.Dataset:
    """The netCDF content of one shot's path (``shots.trace_shot`` result ``res``)."""
    now = _dt.datetime.now(_dt.timezone.utc).replace(microsecond=0).isoformat()
    where = "ball centre, {} (origin: the ring's centre; x towards the board, z up)"
    data = {axis: ("time", np.asarray(res[axis], float), {"units": "m", "long_name": where.format(axis)})
            for axis in ("x", "y", "z")}
    data["phase"] = ("time", np.asarray(res["phase"], np.int8), {
        "units": "1", "long_name": "phase of the motion", "flag_values": np.array([0, 1], np.int8),
        "flag_meanings": "flight on_rim"})
    data["impact_time"] = ("impact", np.asarray(res["impact_time"], float), {"units": "s", "long_name":
                                                                              "time of the impact"})
    for axis in ("x", "y", "z"):
        data[f"impact_{axis}"] = ("impact", np.asarray(res[f"impact_{axis}"], float),
                                  {"units": "m", "long_name": f"ball centre at the impact, {axis}"})
    data["impact_kind"] = ("impact", np.asarray(res["impact_kind"], np.int8), {
        "units": "1", "long_name": "what the ball hit", "flag_values": np.array([1, 2], np.int8),
        "flag_meanings": "rim board"})
    outcome = int(res["outcome"])
    attrs = {"Conventions": "CF-1.8", "title": "One shot from the release to the end (study trace --release)",
             "study": "shot-trace", "outcome": outcome, "outcome_meaning": list(shots.OUTCOME_MEANINGS)[outcome]}
    attrs.update({f"param_{k}": float(v) for k, v in p.as_dict().items()})
    attrs.update({f"release_{k}": float(v) for k, v in release.items()})
    attrs.update({f"setting_{k}": (v if isinstance(v, str) else float(v)) for k, v in shot.items()})
    attrs.update(provenance(command, now))
    time = ("time", np.asarray(res["time"], float), {"units": "s", "long_name": "time since the release"})
    return xr.Dataset(data, coords={"time": time}, attrs=attrs)


def board_x(p: Params, geometry: str) -> float:
    """x [m] of the board's face (``shots.board_x``)."""
    return float(shots.board_x(p, geometry))


BOARD_SPAN = (-0.15, 0.90, 0.90)  # [m] the board drawn: its lower and upper edge above the rim, half its width (FIBA)
ZOOM = 0.45  # [m] half-size of the views around the ring


def _draw_hoop(side, top, p: Params, xb: float) -> None:
    """The ring's tube cross-sections (side) or its annulus (top) and the board's face."""
    for c in (-p.R, p.R):
        side.add_patch(Circle((c, 0.0), p.a, color="k", zorder=4))
    side.plot([xb, xb], BOARD_SPAN[:2], color="0.35", lw=3, zorder=3)
    for radius in (p.R - p.a, p.R + p.a):
        top.add_patch(Circle((0.0, 0.0), radius, fill=False, color="k", lw=1.0, zorder=4))
    top.plot([xb, xb], [-BOARD_SPAN[2], BOARD_SPAN[2]], color="0.35", lw=3, zorder=3)


def _draw_path(axes, ds, p: Params) -> list:
    """The centre's path by phase, the impacts and the ball's outline at each; returns legend handles."""
    x, y, z, phase = (ds[k].values for k in ("x", "y", "z", "phase"))
    handles = []
    for code, style in PHASE_STYLE.items():
        if (phase == code).any():
            line = {k: v for k, v in style.items() if k != "label"}
            for ax, vertical in axes:
                ax.plot(x, np.where(phase == code, vertical, np.nan), **line)
            handles.append(Line2D([], [], **style))
    kinds = ds["impact_kind"].values
    for code, style in IMPACT_STYLE.items():
        pick = kinds == code
        if not pick.any():
            continue
        ix = ds["impact_x"].values[pick]
        for ax, name in ((axes[0][0], "impact_z"), (axes[1][0], "impact_z"), (axes[2][0], "impact_y")):
            iv = ds[name].values[pick]
            ax.plot(ix, iv, ls="", ms=5, zorder=6, **{k: v for k, v in style.items() if k != "label"})
            for cx, cv in zip(ix, iv):
                ax.add_patch(Circle((cx, cv), p.r, fill=False, ls=":", color=style["mfc"], lw=0.8, zorder=5))
        handles.append(Line2D([], [], ls="", **style))
    return handles


def figure(ds) -> Figure:
    """The shot from the side (x-z: the whole path, and around the ring) and from above (x-y, around
    the ring), with the ring, the board, the impacts (the ball's outline dotted) and the rolling phase."""
    p = Params(**{k: float(ds.attrs[f"param_{k}"]) for k in Params().as_dict()})
    fig = Figure(figsize=(12.0, 4.8), layout="constrained")
    whole, near, top = fig.subplots(1, 3, gridspec_kw={"width_ratios": [1.5, 1.0, 1.0]})
    z, y = ds["z"].values, ds["y"].values
    handles = _draw_path(((whole, z), (near, z), (top, y)), ds, p)
    xb = board_x(p, str(ds.attrs["setting_geometry"]))
    for side, above in ((whole, top), (near, top)):
        _draw_hoop(side, above, p, xb)
    handles.append(Line2D([], [], color="k", marker="o", ls="", ms=4, label="ring (tube)"))
    handles.append(Line2D([], [], color="0.35", lw=3, label="board"))
    whole.set(xlabel="x [m] (towards the board)", ylabel="z [m] (above the rim plane)", title="side view")
    near.set(xlabel="x [m]", ylabel="z [m]", title="side view, around the ring")
    top.set(xlabel="x [m]", ylabel="y [m] (sideways)", title="top view, around the ring")
    for ax in (whole, near, top):
        ax.set_aspect("equal", adjustable="box")
    centre = 0.5 * (xb - p.R)
    near.set_xlim(centre - ZOOM, centre + ZOOM)
    near.set_ylim(-ZOOM, ZOOM)
    top.set_xlim(centre - ZOOM, centre + ZOOM)
    top.set_ylim(-ZOOM, ZOOM)
    fig.suptitle(f"shot released at {ds.attrs['release_speed']:.4g} m/s, {ds.attrs['release_angle']:.4g} degree: "
                 f"{ds.attrs['outcome_meaning']}", fontsize=11)
    fig.legend(handles=handles, loc="outside lower center", ncols=3, fontsize=8, frameon=False)
    return fig


def run(args, command: str) -> int:
    """``study trace --release`` or ``study trace FILE --at`` of a shot map: write ``.nc`` and ``.png``."""
    from rimroll.study.rim_trace import parse_name

    name = parse_name(args.name)
    sets = parse_sets(args.sets)
    if args.file is not None:
        if args.release is not None:
            raise UserError("give either --release or a shot FILE with --at, not both")
        release, physical, shot = from_map(args.file, args.at, sets)
    else:
        if args.at:
            raise UserError("--at picks a point of a results FILE; with --release give the release itself")
        release, (physical, shot) = parse_release(args.release), sets
    shot = shot_settings(shot)
    nc = io.check_target(pathlib.Path(args.out) / f"{name}.nc", "the trace")
    png = nc.with_suffix(".png")
    io.check_target(png, "the figure")
    if nc.exists() and not args.force:
        raise UserError(f"{nc} exists; use --force to replace it or --name to write another")
    res, p = compute(release, physical, shot)
    ds = dataset(res, release, p, shot, command)
    with io.atomic_path(nc) as tmp:  # the .nc is moved into place last, after its figure
        io.write_dataset(ds, tmp, (ds.sizes["time"],))
        io.write_figure(figure(io.open_result(tmp)), png)
    print(f"wrote {nc} and {png}: {ds.attrs['outcome_meaning']}, {ds.sizes['impact']} impacts")
    return 0
