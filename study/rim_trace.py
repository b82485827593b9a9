"""``study trace``: one trajectory as a netCDF time series and a figure.

The trajectory comes from ``solver.analysis.phase_trace`` (dense output of every rolling and slipping phase,
the rules of ``solver.simulate``). Its initial state is given directly (``--state``) or picked
from an outcome map (``FILE --at omega1=..,beta=..``), with that file's parameters, scene,
t_max and the map's omega2, omega3. The file holds, over ``time``: the state, the slip
velocity, F2, the friction use |F_t| / (mu F2), the slip speed, the energy, the phase and the
ball centre's position; over ``event``: the time and kind of every event; and in its global
attributes the outcome, t_end and the reason the run ended. A state that leaves the rim at once
(t_end = 0) is a trace of one sample, the initial state at t = 0 (:func:`at_start`). The files are
``<out>/<name>.nc`` and ``.png`` (``--name``: a plain file stem, :func:`parse_name`); the .nc is
moved into place after its figure is written, so a failed plot leaves neither.
"""

from __future__ import annotations

import datetime as _dt
import pathlib
import re

import numpy as np
import xarray as xr
from matplotlib.figure import Figure
from matplotlib.lines import Line2D
from matplotlib.patches import Circle, Patch

from rimroll import solver
from rimroll.solver.analysis import phase_trace as tr
from rimroll.study import cli_text, cubeplots, io
from rimroll.study import plotting as P
from rimroll.study.dataset import params_of, provenance, setting_of
from rimroll.study.registry import PHYSICAL_KEYS, UserError
from rimroll.study.setting_table import lookup

STATE_NAMES = ("beta", "omega1", "omega2", "omega3")
SERIES = {  # name: (units, long_name)
    "beta": ("rad", "height angle of the contact point on the rim's cross-section"),
    "omega1": ("s-1", "transversal angular velocity"),
    "omega2": ("s-1", "orthogonal angular velocity"),
    "omega3": ("s-1", "circular angular velocity"),
    "u1": ("m s-1", "slip velocity of the contact point, component 1 (0 while rolling)"),
    "u3": ("m s-1", "slip velocity of the contact point, component 3 (0 while rolling)"),
    "alpha": ("rad", "angle travelled around the rim's axis"),
    "F2": ("N", "normal contact force, (31) rolling, (41) slipping"),
    "friction_use": ("1", "friction used, |F_t| / (mu F2) (39): 1 while slipping, 0 with mu = inf"),
    "slip_speed": ("m s-1", "slip speed |u| of the contact point"),
    "energy": ("J", "total mechanical energy (60), potential m g rho sin(beta)"),
    "x": ("m", "ball centre, horizontal coordinate (rim's axis at x = y = 0)"),
    "y": ("m", "ball centre, horizontal coordinate perpendicular to x"),
    "z": ("m", "ball centre height above the rim's middle plane"),
}
EVENT_STYLE = {  # how the figure marks each kind of event
    "slip_onset": dict(color="tab:red", ls="--", lw=0.9, label="slip onset (39)"),
    "return_to_rolling": dict(color="tab:green", ls="--", lw=0.9, label="return to rolling"),
    "omega1_zero": dict(color="0.45", ls=":", lw=0.9, label=r"$\omega_1 = 0$"),
    "fall": dict(color="k", ls="-", lw=1.3, label="leaves the rim ($F_2 = 0$)"),
    "periodic": dict(color="tab:purple", ls="-", lw=1.3, label="periodic: second $\\omega_1$ zero"),
}
REVOLUTIONS_SIGN = ("signed: + while alpha grows, anticlockwise seen from above (about the rim's axis e3, up); "
                    "rolling with omega3 > 0 goes round clockwise, alpha' = (u1 - r omega3) / (R - rho cos beta) (19)")
"""The sign of ``revolutions`` (the file's ``revolutions_sign``, the figure's and the summary line's words)."""


def rim_numbers(res: dict) -> dict:
    """What a reader looks for first in one trajectory (``solver.analysis.phase_trace.trace`` result ``res``), up to
    t_end, the end ``solver.simulate`` decides: ``revolutions`` around the rim (alpha(t_end) / 2 pi, signed,
    :data:`REVOLUTIONS_SIGN`; ``simulate``'s output of that name), ``slip_time`` [s] (the time in slip phases,
    ``simulate``'s ``slip_time``) and ``time_on_rim`` [s] (t_end: to the fall, the periodic decision or t_max)."""
    t, t_end = np.asarray(res["t"]), float(res["t_end"])
    alpha = float(np.interp(t_end, t, res["alpha"])) if t.size else 0.0
    slip = sum(min(t1, t_end) - t0 for t0, t1 in _slip_spans(t, res["phase"]) if t0 < t_end)
    return {"revolutions": alpha / (2 * np.pi), "slip_time": float(slip), "time_on_rim": t_end}


def rim_words(numbers: dict) -> str:
    """:func:`rim_numbers` as words: '-1.370 revolutions around the rim (alpha falling: clockwise seen from
    above), 0.12 s slipping, 2.5 s on the rim'."""
    turns = numbers["revolutions"]
    way = "" if turns == 0 else (" (alpha growing: anticlockwise seen from above)" if turns > 0
                                 else " (alpha falling: clockwise seen from above)")
    return (f"{turns:+.3f} revolutions around the rim{way}, {numbers['slip_time']:.4g} s slipping, "
            f"{numbers['time_on_rim']:.4g} s on the rim")


# ------------------------------------------------------------------ the initial state
def parse_state(text: str) -> np.ndarray:
    """'BETA,OMEGA1,OMEGA2,OMEGA3' -> array (4,) [rad, 1/s, 1/s, 1/s]; UserError otherwise."""
    try:
        x = np.array([cli_text.number(v) for v in text.split(",")])
    except ValueError:
        x = np.empty(0)
    if x.shape != (4,) or not np.all(np.isfinite(x)):
        raise UserError(f"--state {text!r}: expected four finite numbers BETA,OMEGA1,OMEGA2,OMEGA3 [rad, 1/s]")
    return x


NAME_MAX = 200  # characters of --name: room for the suffix and the temporary names of the atomic writes
_NAME = re.compile(r"[A-Za-z0-9_-][A-Za-z0-9._-]*")


def parse_name(text: str) -> str:
    """``--name``: the stem of the files ``<out>/<name>.nc`` and ``.png`` (a trailing ``.nc`` is
    dropped); UserError unless it is a plain file name of letters, digits, '-', '_' and '.', not
    starting with '.', at most :data:`NAME_MAX` characters."""
    name = text[:-3] if text.endswith(".nc") else text
    if not (_NAME.fullmatch(name) and len(name) <= NAME_MAX):
        raise UserError(f"--name {text!r}: expected a file name without a folder: letters, digits, '-', '_' and "
                        f"'.', not starting with '.', at most {NAME_MAX} characters (a trailing .nc is dropped)")
    return name


def parse_sets(words: list[str]) -> dict:
    """``--set KEY=VALUE`` words of physical parameters -> {key: float} (``study.cli_text``)."""
    out = {}
    for key, value in cli_text.parse(words, "--set", "KEY=VALUE", "--set mu=inf"):
        if key not in PHYSICAL_KEYS:
            raise UserError(f"--set {key}={value}: expected KEY=VALUE with KEY one of {' '.join(PHYSICAL_KEYS)}")
        try:
            out[key] = cli_text.number(value)
        except ValueError:
            raise UserError(f"--set {key}={value}: VALUE must be a number (inf allowed for mu)") from None
    return out


def _params(**values) -> solver.Params:
    try:
        return solver.Params(**values)
    except ValueError as exc:
        raise UserError(str(exc)) from None


def _parse_at(words) -> dict:
    """``--at DIM=VALUE,DIM=VALUE,...`` words (the option may be repeated) -> {dim: value text}
    (``study.cli_text``); a dimension given twice is a UserError."""
    out = {}
    for text in [words] if isinstance(words, str) else words:
        for key, value in cli_text.split(text, "--at", "DIM=VALUE,DIM=VALUE,...",
                                         "--at omega1=2,beta=1.1,scene=slipping"):
            if key in out:
                raise UserError(f"--at {key} is given twice ({out[key]} and {value}): one value per axis")
            out[key] = value
    return out


def _values_text(ds, dim: str) -> str:
    """The values of the axis ``dim`` of ``ds`` as a message lists them: scene labels, or numbers (at most 8)."""
    coord = ds[dim].values
    words = [P.scene_key(v) if dim == "scene" else f"{v:g}" if coord.dtype.kind in "fiu" else str(v) for v in coord]
    return ", ".join(words[:8]) + (f", ... ({len(words)} values)" if len(words) > 8 else "")


def _index(ds, dim: str, value: str) -> int:
    """Index along ``dim`` of ``value``: nearest number, or a label (scene labels work on old files too).

    A number must be finite (or +-inf where the axis holds it, a swept mu = inf) and lie on the axis
    or within half a grid step of its ends, as ``study plot --select`` (an axis of one value: that
    value): omega1=55 on an axis ending at 20 is not moved to 20."""
    coord = ds[dim].values
    if coord.dtype.kind in "fiu":
        try:
            number = cli_text.number(value)
        except ValueError:
            number = None
            if dim == "scene" and value in P.SCENE_KEYS:
                return int(np.argmin(np.abs(coord - P.SCENE_KEYS.index(value))))
        if number is not None:
            coord = coord.astype(float)
            exact = np.flatnonzero(coord == number)
            if exact.size:
                return int(exact[0])
            if np.isfinite(number) and cubeplots.on_axis(coord, number):
                return int(np.argmin(np.where(np.isfinite(coord), np.abs(coord - number), np.inf)))
            raise UserError(f"--at {dim}={value}: outside the file's {dim} axis ({_values_text(ds, dim)}); a "
                            "finite number on the axis is taken to the nearest grid point")
    labels = [P.scene_key(v) if dim == "scene" else str(v) for v in coord]
    if value in labels:
        return labels.index(value)
    raise UserError(f"--at {dim}={value}: not a value of the file's {dim} ({_values_text(ds, dim)})")


def from_map(path, at_text: str | list[str], sets: dict) -> tuple[np.ndarray, solver.Params, float, dict]:
    """(state, params, t_max [s], provenance) of the point ``--at`` of an outcome map file."""
    ds = io.open_result(pathlib.Path(path))
    if "outcome" not in ds:
        raise UserError(f"{path}: not an outcome map (no 'outcome' variable); study trace --at needs fig11-13 "
                        "or outcome-cube results")
    at = _parse_at(at_text)
    dims = ds["outcome"].dims
    unknown = set(at) - set(dims)
    if unknown:
        raise UserError(f"--at {','.join(sorted(unknown))}: not a dimension of {path} ({', '.join(dims)})")
    pick = {}
    for dim in dims:
        if dim in at:
            pick[dim] = _index(ds, dim, at[dim])
        elif ds.sizes[dim] == 1:
            pick[dim] = 0
        else:
            raise UserError(f"--at needs a value for {dim!r}, an axis of {path} with {ds.sizes[dim]} values "
                            f"({_values_text(ds, dim)})")
    point = ds.isel(pick)  # every axis at one value: a swept parameter or setting is now the point's scalar
    try:
        values = params_of(point).as_dict()  # the file's parameters, a scene's mu, k_r, k_d, a swept one's value
    except ValueError as exc:
        raise UserError(f"{path}: {exc}") from None
    values.update(sets)
    if "rho_over_R" in point.coords:
        x = float(point["rho_over_R"])
        others = {k: v for k, v in values.items() if k not in ("r",)}
        try:
            params = solver.Params.from_rho_over_R(x, **others)
        except ValueError as exc:
            raise UserError(str(exc)) from None
    else:
        params = _params(**values)
    state = np.array([_recorded(point, path, name) for name in STATE_NAMES])
    t_max = _recorded(point, path, "t_max")
    where = ", ".join(f"{d}={P.scene_key(point[d].values[()]) if d == 'scene' else f'{float(point[d]):g}'}"
                      for d in dims)
    prov = {"source_file": str(path), "source_study": str(ds.attrs.get("study", "")), "source_point": where,
            "source_outcome": int(point["outcome"]),
            "source_t_end": float(point["t_end"]) if "t_end" in point else np.nan}
    if "rtol" in ds.attrs or "setting_rtol" in ds.attrs:
        prov["source_rtol"] = _recorded(point, path, "rtol")
    return state, params, t_max, prov


def _recorded(point, path, name: str) -> float:
    """The setting ``name`` of one point of a map (its coordinate, or the file's attribute); UserError
    if the file lacks it."""
    try:
        return float(setting_of(point, name))
    except (KeyError, ValueError) as exc:
        raise UserError(f"{path}: {exc.args[0] if exc.args else exc}") from None


# ------------------------------------------------------------------ following a periodic orbit
MAX_PERIODS = 1000


def follow(res: dict, params: solver.Params, periods: int, rtol: float, atol: float, n: int) -> dict:
    """``res`` (a trace that ended periodic: its second transversal omega1 zero) continued for
    ``periods`` more periods, half a period at a time: each piece is a new trace from the state
    half a half period before the end so far (where omega1 is far from 0), which stops at its
    second omega1 zero, half a period past that end; what lies beyond the end is appended, with
    the time, the angle round the rim and the centre's x, y carried on. The continuation's stops
    are marked as omega1 zeros; ``half_periods`` lists the half period each piece measured (the
    orbit repeats if they agree with the first), ``t_followed`` [s] is its end. The outcome,
    t_end and reason stay those of the first trace (what ``simulate`` decides)."""
    out = {k: v for k, v in res.items() if isinstance(v, np.ndarray) and v.shape == res["t"].shape}
    events_t, events_k = [res["event_t"]], [res["event_kind"]]
    half = float(res["half_period"])
    halves = []
    for _ in range(2 * periods):
        end = out["t"][-1]
        i = int(np.argmin(np.abs(out["t"] - (end - 0.5 * half))))
        start = np.array([out[k][i] for k in STATE_NAMES])
        piece = tr.trace(start, params, t_max=3.0 * half + 1.0, rtol=rtol, atol=atol, n=max(n // (2 * periods), 100))
        if piece["reason"] != "periodic":
            break
        halves.append(float(piece["half_period"]))
        d = np.hypot(piece["x"], piece["y"])
        piece["alpha"] = piece["alpha"] + out["alpha"][i]
        piece["x"], piece["y"] = d * np.cos(piece["alpha"]), d * np.sin(piece["alpha"])
        piece["t"] = piece["t"] + out["t"][i]
        after = piece["t"] > end * (1 + 1e-12)
        out = {k: np.concatenate([v, piece[k][after]]) for k, v in out.items()}
        # the piece's own events past the end; its stop is an omega1 zero (recorded as such), not a new decision
        late = piece["event_t"] + piece["t"][0] > end * (1 + 1e-9)
        late &= ~np.isin(piece["event_kind"], ("start", "periodic"))
        events_t.append(piece["event_t"][late] + piece["t"][0])
        events_k.append(piece["event_kind"][late])
    merged = {**res, **out, "event_t": np.concatenate(events_t), "event_kind": np.concatenate(events_k)}
    merged["half_periods"] = np.array(halves)
    merged["t_followed"] = float(merged["t"][-1])
    return merged


# ------------------------------------------------------------------ a trace that ends at once
def at_start(res: dict, state, params: solver.Params) -> dict:
    """``res`` with one sample, the initial state at t = 0, where it has none: a state that leaves
    the rim at once (F2 <= 0 from the start, or a slip onset that loses the contact at t = 0) ends
    at t_end = 0 with no phase to sample. The sample is the rolling initial state (u1 = u3 = 0,
    alpha = 0) with its F2 [N], friction use and energy [J], as ``solver.analysis.phase_trace.sample``
    computes them; the outcome, events and reason stay the trace's."""
    if res["t"].size:
        return res
    x0 = np.append(np.asarray(state, dtype=float), 0.0)  # (beta, omega1, omega2, omega3, alpha) of a rolling phase
    start = tr.Phase(tr.ROLLING, 0.0, 0.0, lambda t: np.repeat(x0[:, None], np.size(t), axis=1))
    return {**res, **tr.sample({"t_end": 0.0, "phases": [start]}, params, 2)}


# ------------------------------------------------------------------ the file
def dataset(res: dict, state, params: solver.Params, t_max: float, rtol: float, atol: float, command: str,
            extra: dict | None = None) -> xr.Dataset:
    """The netCDF content of one trace (``solver.analysis.phase_trace.trace`` result ``res``)."""
    now = _dt.datetime.now(_dt.timezone.utc).replace(microsecond=0).isoformat()
    time = ("time", res["t"], {"units": "s", "long_name": "time since the initial state"})
    data = {name: ("time", res[name], {"units": u, "long_name": ln}) for name, (u, ln) in SERIES.items()}
    data["phase"] = ("time", res["phase"].astype(np.int8), {
        "units": "1", "long_name": "phase of the motion", "flag_values": np.array(list(tr.PHASE_MEANINGS), np.int8),
        "flag_meanings": " ".join(tr.PHASE_MEANINGS.values())})
    kinds = list(tr.EVENT_KINDS)
    codes = np.array([kinds.index(k) if k in kinds else kinds.index("t_max") for k in res["event_kind"]], np.int8)
    data["event_time"] = ("event", res["event_t"], {"units": "s", "long_name": "time of the event"})
    data["event_kind"] = ("event", codes, {"units": "1", "long_name": "kind of the event",
                                           "flag_values": np.arange(len(kinds), dtype=np.int8),
                                           "flag_meanings": " ".join(kinds)})
    outcome = int(res["outcome"])
    meaning = solver.OUTCOME_MEANINGS.get(outcome, f"outcome_{outcome}").split(":")[0]
    attrs = {"Conventions": "CF-1.10", "title": "One trajectory of a ball on the rim (study trace)", "study": "trace"}
    attrs.update({f"param_{k}": float(v) for k, v in params.as_dict().items()})
    attrs["param_rho"] = float(params.rho)
    attrs.update({f"initial_{n}": float(v) for n, v in zip(STATE_NAMES, state)})
    attrs.update({"t_max": float(t_max), "rtol": float(rtol), "atol": float(atol), "method": "scipy DOP853",
                  "outcome": outcome, "outcome_meaning": meaning, "t_end": float(res["t_end"]),
                  "reason": str(res["reason"]), "half_period": float(res["half_period"]),
                  "slip_phases": int(res["slip_phases"])})
    numbers = rim_numbers(res)
    attrs.update({"revolutions": numbers["revolutions"], "revolutions_sign": REVOLUTIONS_SIGN,
                  "slip_time": numbers["slip_time"], "time_on_rim": numbers["time_on_rim"]})
    if "half_periods" in res:
        halves = res["half_periods"]
        attrs.update({"periods_followed": int(halves.size // 2), "t_followed": float(res["t_followed"]),
                      "half_periods_followed": halves if halves.size else np.array([np.nan])})
    attrs.update(extra or {})
    attrs.update(provenance(command, now))
    return xr.Dataset(data, coords={"time": time}, attrs=attrs)


# ------------------------------------------------------------------ the figure
def _slip_spans(t, phase):
    """[(t0, t1)] of the slipping stretches of a sampled trace."""
    slip = np.asarray(phase) == tr.SLIPPING
    edges = np.flatnonzero(np.diff(np.concatenate([[0], slip.astype(int), [0]])))
    return [(t[a], t[b - 1]) for a, b in zip(edges[::2], edges[1::2])]


def figure(ds) -> Figure:
    """beta, omega, F2 and energy against time (slip phases shaded, events marked) and the centre's
    path from above and from the side, rim and ball to scale; outcome, t_end and reason in the title."""
    fig = Figure(figsize=(13.0, 9.5), layout="constrained")
    grid = fig.add_gridspec(4, 2, width_ratios=(1.55, 1.0))
    left = [fig.add_subplot(grid[0, 0])]
    left += [fig.add_subplot(grid[k, 0], sharex=left[0]) for k in (1, 2, 3)]
    top, side = fig.add_subplot(grid[0:2, 1]), fig.add_subplot(grid[2:4, 1])
    t = ds["time"].values
    a = ds.attrs
    dot = dict(marker="o", ms=4) if t.size == 1 else {}  # a trace that ends at t = 0: one sample, drawn as a dot
    left[0].plot(t, ds["beta"], color="k", lw=1.1, **dot)
    left[0].set_ylabel(r"$\beta$ [rad]")
    for name, colour in (("omega1", "C0"), ("omega2", "C1"), ("omega3", "C2")):
        left[1].plot(t, ds[name], color=colour, lw=1.1, label=rf"$\omega_{name[-1]}$", **dot)
    left[1].set_ylabel(r"$\omega$ [1/s]")
    left[1].legend(loc="best", fontsize=8, ncol=3)
    left[2].plot(t, ds["F2"], color="k", lw=1.1, **dot)
    left[2].axhline(0.0, color="0.5", lw=0.6)
    left[2].set_ylabel(r"$F_2$ [N]")
    if np.isfinite(a["param_mu"]):
        twin = left[2].twinx()
        twin.plot(t, ds["friction_use"].clip(0, 1.2), color="tab:red", lw=0.8, alpha=0.7, **dot)
        twin.set_ylabel(r"$|F_t|/(\mu F_2)$ [-]", color="tab:red")
        twin.set_ylim(0, 1.25)
    e = ds["energy"].values
    left[3].plot(t, e - e[0], color="k", lw=1.1, **dot)
    left[3].set_ylabel(r"$E(t) - E(0)$ [J]")
    left[3].set_xlabel("time $t$ [s]")
    spans = _slip_spans(t, ds["phase"].values)
    kinds = list(ds["event_kind"].attrs["flag_meanings"].split())
    events = [(float(tt), kinds[int(k)]) for tt, k in zip(ds["event_time"].values, ds["event_kind"].values)]
    shown = set()
    t_lo, t_hi = (t[0], t[-1]) if t[-1] > t[0] else (t[0] - 0.05, t[0] + 0.05)  # one sample: 0.1 s around it
    for ax in left:
        for t0, t1 in spans:
            ax.axvspan(t0, max(t1, t0 + 1e-3 * (t_hi - t_lo)), color="tab:red", alpha=0.15, lw=0)
        for tt, kind in events:
            if kind in EVENT_STYLE:
                ax.axvline(tt, **{k: v for k, v in EVENT_STYLE[kind].items() if k != "label"})
                shown.add(kind)
        ax.grid(alpha=0.3)
        ax.set_xlim(t_lo, t_hi)
    handles = [Line2D([], [], **EVENT_STYLE[k]) for k in EVENT_STYLE if k in shown]
    if spans:
        handles.insert(0, Patch(color="tab:red", alpha=0.15, label="slipping"))
    if handles:
        left[0].legend(handles=handles, loc="best", fontsize=8)
    _paths(top, side, ds)
    state = ", ".join(f"{a[f'initial_{n}']:g}" for n in STATE_NAMES)
    scene = r"$\mu=\infty$" if np.isinf(a["param_mu"]) else rf"$\mu={a['param_mu']:g}$"
    for key, symbol, units in (("k_r", "k_r", "1/s"), ("k_d", "k_d", "1/s"), ("c_r", "c_r", "m"), ("c_d", "c_d", "m"),
                               ("rho_air", r"\rho_{air}", "kg/m$^3$")):
        if a.get(f"param_{key}", 0.0):
            scene += rf", ${symbol}={a[f'param_{key}']:g}$ {units}"
    label = P.OUTCOME_PALETTE.label(int(a["outcome"]))
    why = {"fall": "left the rim, F2 = 0", "periodic": "second transversal zero of omega1",
           "t_max": "reached t_max"}.get(str(a["reason"]), str(a["reason"]).replace("_", " "))
    if t.size == 1 and str(a["reason"]) == "fall":
        why = f"the ball leaves the rim at t = 0: F2 = {float(ds['F2'][0]):.4g} N at the initial state"
    if "t_followed" in a:
        why += f"; followed {int(a['periods_followed'])} more periods, to t = {float(a['t_followed']):.4g} s"
    rim = rim_words({k: float(a[k]) for k in ("revolutions", "slip_time", "time_on_rim")}) if "revolutions" in a else ""
    fig.suptitle(f"{label} at t_end = {a['t_end']:.6g} s ({why})\n" + (f"{rim}\n" if rim else "")
                 + rf"from ($\beta$, $\omega_1$, $\omega_2$, $\omega_3$) = ({state}); {scene}", fontsize=11)
    return fig


def _paths(top, side, ds) -> None:
    a = ds.attrs
    R, rim_a, r, rho = a["param_R"], a["param_a"], a["param_r"], a["param_rho"]
    x, y, z = ds["x"].values, ds["y"].values, ds["z"].values
    colour = P.OUTCOME_PALETTE.colour(int(a["outcome"]))
    # from above: the rim is a ring of radii R - a .. R + a; the centre's path; the ball at start and end
    for radius in (R - rim_a, R + rim_a):
        top.add_patch(Circle((0, 0), radius, fill=False, ec="0.3", lw=1.0))
    top.plot(x, y, color="k", lw=0.9)
    for k, style in ((0, dict(ls="--")), (-1, dict(ls="-"))):
        top.add_patch(Circle((x[k], y[k]), r, fill=False, ec=colour, lw=1.2, **style))
    top.plot(x[:1], y[:1], "o", color="k", ms=3)
    top.set_aspect("equal")
    lim = R + rim_a + 2 * r
    top.set_xlim(-lim, lim)
    top.set_ylim(-lim, lim)
    top.set_title("centre path from above (rim and ball to scale; ball dashed at the start)", fontsize=9)
    top.set_xlabel("x [m]")
    top.set_ylabel("y [m]")
    # from the side: the rim's cross-section (a circle of radius a at distance R), the centre's
    # path in (distance from the axis, height), the ball at start (dashed) and end
    d = np.hypot(x, y)
    side.add_patch(Circle((R, 0), rim_a, fc="0.6", ec="0.3"))
    side.add_patch(Circle((R, 0), rho, fill=False, ec="0.75", ls=":", lw=0.8))
    side.plot(d, z, color="k", lw=0.9)
    for k, style in ((0, dict(ls="--")), (-1, dict(ls="-"))):
        side.add_patch(Circle((d[k], z[k]), r, fill=False, ec=colour, lw=1.2, **style))
    side.set_aspect("equal")
    side.set_xlim(R - rho - r - 0.02, R + rho + r + 0.02)
    side.set_ylim(-rho - r - 0.02, rho + r + 0.02)
    side.axvline(R, color="0.8", lw=0.6)
    side.set_title("centre path from the side (rim's cross-section grey)", fontsize=9)
    side.set_xlabel("distance from the rim's axis [m]")
    side.set_ylabel("height [m]")


# ------------------------------------------------------------------ the command
def run(args, command: str) -> int:
    """``study trace``: compute, write ``<out>/<name>.nc`` and ``.png``, print where."""
    sets = parse_sets(args.sets)
    name = parse_name(args.name)
    if (args.state is None) == (args.file is None):
        raise UserError("give either --state BETA,OMEGA1,OMEGA2,OMEGA3 or a results FILE with --at DIM=VALUE,...")
    if args.file is not None:
        if not args.at:
            raise UserError(f"{args.file}: say which point of the map with --at, "
                            "e.g. --at omega1=2,beta=1.1,scene=slipping")
        state, params, t_max, extra = from_map(args.file, args.at, sets)
    else:
        if args.at:
            raise UserError("--at picks a point of a results FILE; with --state give the state itself")
        state, params, t_max, extra = parse_state(args.state), _params(**sets), 20.0, {}
    if args.t_max is not None:
        t_max = args.t_max
    given = (("--t-max", "t_max", t_max), ("--rtol", "rtol", args.rtol), ("--atol", "atol", args.atol))
    for option, key, value in given:
        problem = lookup(key).problem(value)  # the setting table's rule of the setting of that name
        if problem:
            raise UserError(f"{option} {value!r}: {problem}")
    if args.samples < 2:
        raise UserError(f"--samples must be >= 2; got {args.samples}")
    try:
        tr.check_n(args.samples)  # its memory, before the integration
    except ValueError as exc:
        raise UserError(str(exc).replace("`n`", "--samples", 1)) from None
    if not 0 <= args.periods <= MAX_PERIODS:
        raise UserError(f"--periods must be an integer 0 <= N <= {MAX_PERIODS}; got {args.periods}")
    nc = io.check_target(pathlib.Path(args.out) / f"{name}.nc", "the trace")
    io.check_target(nc.with_suffix(".png"), "the figure")
    if nc.exists() and not args.force:
        raise UserError(f"{nc} exists; use --force to replace it or --name to write another")
    res = at_start(tr.trace(state, params, t_max=t_max, rtol=args.rtol, atol=args.atol, n=args.samples), state,
                   params)
    if args.periods and res["reason"] == "periodic":
        res = follow(res, params, args.periods, args.rtol, args.atol, args.samples)
    ds = dataset(res, state, params, t_max, args.rtol, args.atol, command, extra)
    png = nc.with_suffix(".png")
    with io.atomic_path(nc) as tmp:  # the .nc is moved into place last, after its figure: a failed plot leaves neither
        io.write_dataset(ds, tmp, (ds.sizes["time"],))
        io.write_figure(figure(io.open_result(tmp)), png)
    label = solver.OUTCOME_MEANINGS.get(res["outcome"], str(res["outcome"])).split(":")[0]
    more = ""
    if "half_periods" in res:
        more = f"; followed {res['half_periods'].size // 2} more periods to t = {res['t_followed']:.6g} s"
    elif res["reason"] == "periodic":
        more = "; --periods N follows the orbit N more periods"
    elif res["reason"] == "fall" and res["t_end"] == 0.0:
        more = f"; the ball leaves the rim at t = 0 (F2 = {res['F2'][0]:.4g} N at the initial state)"
    point = f" from {extra['source_point']} of {extra['source_file']}" if extra and "source_point" in extra else ""
    print(f"wrote {nc} and {png}{point}: {label} at t_end = {res['t_end']:.6g} s ({res['reason']}); "
          f"{rim_words(rim_numbers(res))}{more}")
    return 0
