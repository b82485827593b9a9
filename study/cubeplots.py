"""Figures of parameter cubes: every swept axis in view, and a slice drawn as the section's map.

A cube is a file with swept settings (global attribute ``swept``: ``--set mu=0.25,0.5,1,2`` makes
``mu`` an axis). Its figure is small multiples: one panel per swept axis, a quantity's mean over
the section (an outcome's fraction, a region's area) against that axis, and its range over the
other swept axes shaded; with at most :data:`MAX_MAPS` slices, the section's map of each slice
below them. ``study plot FILE --select mu=1,k_r=0`` draws the cube with those axes held (nearest
values); held on every swept axis, what is left is one section, and the study draws its map as
the matching paper figure does (Fig. 8: realisable regions over (beta0, omega30); Figs. 11-13:
outcomes over (omega1, beta)).

Drawing only; the studies (``rimroll.workflows.cubes``, ``make-probability``) say what to draw.
"""

from __future__ import annotations

import itertools

import numpy as np
from matplotlib.figure import Figure
from matplotlib.patches import Patch

MAX_MAPS = 6
"""A cube with at most this many slices also shows the section's map of each."""
UNIT_TEXT = {"s-1": "1/s", "m s-1": "m/s", "1": "-", "": "-", "rad": "rad", "s": "s"}
SYMBOLS = {"mu": r"$\mu$", "k_r": r"$k_r$", "k_d": r"$k_d$", "c_r": r"$c_r$", "c_d": r"$c_d$",
           "rho_air": r"$\rho_{air}$", "C_D": r"$C_D$", "omega2": r"$\omega_2$", "omega3": r"$\omega_3$",
           "j": r"$j$", "rho_over_R": r"$\rho/R$", "v_throw": r"$v_{throw}$", "sigma": r"$\sigma$"}
"""How a figure writes a swept setting."""
WORDS = {"mu": "friction coefficient", "k_r": "rolling resistance", "k_d": "drilling resistance",
         "c_r": "Coulomb rolling resistance", "c_d": "Coulomb drilling resistance", "rho_air": "air density",
         "C_D": "drag coefficient",
         "omega2": "initial", "omega3": "initial", "j": "inertia factor", "rho_over_R": "ball size",
         "v_throw": "throw speed", "sigma": "noise level"}
"""The words before the symbol in an axis label (the coordinate's long_name otherwise)."""
BAND = dict(alpha=0.18, lw=0)
MIN_WIDTH = 8.0
"""[in] Narrowest cube figure: the title and the legend below the panels fit (one swept axis without maps
drew 4.5 in, and both were clipped)."""
SMALL_SHARE = 0.1
"""A curve whose largest value is below this share of the largest on its axis gets a log scale
(:func:`fraction_scale`): a periodic fraction of 0.02 beside 0.7 looked flat on a linear one."""


def select(ds, values: dict):
    """``ds`` at the value of each swept axis nearest ``values`` ({dim: number}; inf picks mu = inf
    exactly, and a finite value the nearest finite one; a label, {dim: str}, picks that label)."""
    pick = {}
    for dim, value in values.items():
        if isinstance(value, str):
            pick[dim] = int(np.flatnonzero(np.asarray(ds[dim].values).astype(str) == value)[0])
            continue
        coord = np.asarray(ds[dim].values, dtype=float)
        exact = np.flatnonzero(coord == value)
        with np.errstate(invalid="ignore"):
            dist = np.where(np.isfinite(coord), np.abs(coord - value), np.inf)
        pick[dim] = int(exact[0]) if exact.size else int(np.argmin(dist) if np.isfinite(dist).any() else 0)
    return ds.isel(pick)


def on_axis(coord, value: float) -> bool:
    """Whether the finite ``value`` lies on the axis ``coord`` (its finite values), or within half a grid
    step of its ends (an axis of one value: that value, to 1e-9 of it): the nearest grid value then
    stands for it (``study plot --select``, ``study trace --at``); beyond, it names no point of the axis."""
    coord = np.asarray(coord, dtype=float)
    finite = np.sort(coord[np.isfinite(coord)])
    if finite.size == 0:
        return False
    lo, hi = float(finite[0]), float(finite[-1])
    margin = 0.5 * (hi - lo) / (finite.size - 1) if finite.size > 1 else 1e-9 * max(abs(hi), 1.0)
    return lo - margin <= value <= hi + margin


def swept(ds) -> list[str]:
    """The file's swept axes that still vary in ``ds`` (after a selection: those not held)."""
    names = str(ds.attrs.get("swept", "")).split()
    return [n for n in names if n in ds.dims and ds.sizes[n] > 1]


def held(ds) -> dict:
    """{name: value} of the file's swept axes that ``ds`` holds at one value (a selection)."""
    out = {}
    for name in str(ds.attrs.get("swept", "")).split():
        if name in ds.coords and ds[name].size == 1:
            out[name] = float(ds[name].values.ravel()[0])
    return out


def value_text(value: float) -> str:
    """A swept value as a figure writes it: 0.25, 1, ∞."""
    return "\u221e" if np.isinf(value) else f"{value:.4g}"


def quantity_text(ds, name: str, value: float) -> str:
    """'mu = 1', 'k_r = 0.02 1/s': a setting's symbol, value and units (mathtext)."""
    from rimroll.study.setting_table import lookup

    raw = str(ds[name].attrs.get("units", "")) if name in ds.variables else lookup(name).units
    units = UNIT_TEXT.get(raw, raw)
    unit = "" if units in ("-", "") or np.isinf(value) else f" {units}"
    return f"{SYMBOLS.get(name, name)} = {value_text(value)}{unit}"


def axis_label(ds, name: str) -> str:
    """'friction coefficient $\\mu$ [-]': the axis' long_name, symbol and units."""
    attrs = ds[name].attrs
    units = UNIT_TEXT.get(str(attrs.get("units", "")), str(attrs.get("units", "")))
    return f"{WORDS.get(name, attrs.get('long_name', name))} {SYMBOLS.get(name, '')} [{units}]".replace("  ", " ")


def held_text(ds, names=(), fig=None, fontsize: float = 11, lead: int = 0) -> str:
    """The settings ``names`` (those a study can sweep) that ``ds`` holds at one value, by a selection
    or because the run gave one value, as text ('' if none). With ``fig``: broken into lines (at the
    commas) that fit its width at ``fontsize`` [pt], the first line ``lead`` characters shorter (the
    title's words before it)."""
    values = held(ds)
    for name in names:
        if name not in values and name not in swept(ds):
            key = next((k for k in (f"setting_{name}", f"param_{name}") if k in ds.attrs), None)
            if key is not None:
                values[name] = float(ds.attrs[key])
    words = [quantity_text(ds, k, v) for k, v in values.items() if _acts(ds, k, values)]
    if fig is None:
        return ", ".join(words)
    return fit_lines(words, fig, fontsize, lead)


def _acts(ds, name: str, values: dict) -> bool:
    """Whether the setting ``name`` acts in ``ds``: not a parameter whose switch (``ACTS_ONLY_WITH``: C_D's is
    rho_air) is 0 or absent where it is held (a swept switch: it acts where the switch is on)."""
    from rimroll.solver.physics.params import ACTS_ONLY_WITH

    switch = ACTS_ONLY_WITH.get(name)
    if switch is None or switch in swept(ds):
        return True
    value = values.get(switch, next((float(ds.attrs[k]) for k in (f"setting_{switch}", f"param_{switch}")
                                     if k in ds.attrs), 0.0))
    return value != 0


def fraction_scale(ax, curves) -> bool:
    """Put ``ax`` on a symmetric-log scale (linear from 0 to the power of ten below the smallest curve's peak, at
    least 0.001; logarithmic above) when one of ``curves`` (arrays of fractions) stays below
    :data:`SMALL_SHARE` of the largest value among them while above 0: small fractions then show their changes.
    Returns whether it did."""
    peaks = [float(np.nanmax(c)) for c in curves if np.size(c) and np.any(np.isfinite(c))]
    top = max(peaks, default=0.0)
    small = [p for p in peaks if 0 < p < SMALL_SHARE * top]
    if not small:
        return False
    linthresh = max(1e-3, 10.0 ** np.floor(np.log10(min(small))))
    ax.set_yscale("symlog", linthresh=linthresh, linscale=0.4)
    ax.set_ylim(0.0, 1.02 if top > 0.5 else top * 1.2)
    ticks = [t for t in (0.0, 0.001, 0.002, 0.005, 0.01, 0.02, 0.05, 0.1, 0.2, 0.5, 1.0)
             if (t == 0 or t >= linthresh) and t <= ax.get_ylim()[1]]
    ax.set_yticks(ticks, [f"{t:g}" for t in ticks])
    return True


def fit_lines(words: list[str], fig, fontsize: float = 11, lead: int = 0) -> str:
    """``words`` joined by ', ' into lines that fit the width of ``fig`` at ``fontsize`` [pt] (a
    character taken as 0.55 em wide, mathtext markup counted as if drawn: a safe overestimate)."""
    width = max(20, int(fig.get_figwidth() * 72 / (0.55 * fontsize) * 0.92))
    lines, line = [], ""
    for word in words:
        room = width - (lead if not lines else 0)
        if line and len(line) + 2 + len(word) > room:
            lines.append(line + ",")
            line = word
        else:
            line = f"{line}, {word}" if line else word
    return "\n".join([*lines, line])


def slices(ds, dims) -> list[dict]:
    """Every slice of the swept axes ``dims``: ``{dim: index}``, in C order."""
    return [dict(zip(dims, idx)) for idx in itertools.product(*(range(ds.sizes[d]) for d in dims))]


def slice_text(ds, pick: dict) -> str:
    """The values of one slice, as text: 'mu = 0.5, k_r = 0 1/s'."""
    return ", ".join(quantity_text(ds, d, float(ds[d].values[i])) for d, i in pick.items())


def layout(ds, n_maps: int, panel: float = 3.9, legend: float = 0.6):
    """(Figure, axes of the sweep panels, axes of the maps): one panel per swept axis in the top row;
    ``n_maps`` maps below (up to three in a row; four as 2 x 2)."""
    def grid(n):  # (rows, columns): up to three in a row, four as 2 x 2
        cols = n if n <= 3 else int(np.ceil(np.sqrt(n)))
        return -(-n // max(cols, 1)), cols

    (s_rows, s_cols), (rows, cols) = grid(len(swept(ds))), grid(n_maps)
    width = max(max(s_cols, cols) * panel + legend, MIN_WIDTH)
    fig = Figure(figsize=(width, 1.6 + 3.3 * s_rows + 3.6 * rows), layout="constrained")
    if not n_maps:
        top = fig
    else:
        top, bottom = fig.subfigures(2, 1, height_ratios=[1.0 + 3.3 * s_rows, 3.6 * rows])
    sweep = list(np.atleast_1d(top.subplots(s_rows, s_cols, sharey=True, squeeze=False)).ravel())
    for ax in sweep[len(swept(ds)):]:
        ax.set_visible(False)
    sweep = sweep[:len(swept(ds))]
    if not n_maps:
        return fig, sweep, []
    maps = list(np.atleast_1d(bottom.subplots(rows, cols, squeeze=False)).ravel())
    for ax in maps[n_maps:]:
        ax.set_visible(False)
    return fig, sweep, maps[:n_maps]


def _positions(values) -> tuple[np.ndarray, bool]:
    """x positions of an axis' values: the values themselves, or 0, 1, ... when one is inf (then
    the ticks name the values); and whether they are positions."""
    values = np.asarray(values, dtype=float)
    if np.all(np.isfinite(values)):
        return values, False
    return np.arange(values.size, dtype=float), True


def sweep_panels(axes, ds, series, ylabel: str, ylim=None) -> list:
    """One panel per swept axis of ``ds`` (``axes`` in the order of :func:`swept`): each of ``series``
    = [(label, DataArray over the swept axes, colour)], its mean over the other swept axes against
    this one (line and markers), their range shaded. Returns the legend handles."""
    dims = swept(ds)
    for ax, d in zip(axes, dims):
        x, categorical = _positions(ds[d].values)
        others = [o for o in dims if o != d]
        for label, da, colour in series:
            da = da.load() if hasattr(da, "load") else da
            mean = (da.mean(others) if others else da).transpose(d).values
            ax.plot(x, mean, "o-", color=colour, lw=1.6, ms=5, label=label)
            if others:
                ax.fill_between(x, da.min(others).transpose(d).values, da.max(others).transpose(d).values,
                                color=colour, **BAND)
        if categorical or x.size <= 8:
            ax.set_xticks(x, [value_text(v) for v in ds[d].values])
        ax.set_xlabel(axis_label(ds, d))
        ax.grid(alpha=0.3)
        if ylim is not None:
            ax.set_ylim(*ylim)
        if ylim is not None and ylim[1] <= 1.5:  # fractions: a small one on a log scale
            fraction_scale(ax, [da.values for _, da, _ in series])
    for ax in axes:
        if ax.get_subplotspec().is_first_col():
            ax.set_ylabel(ylabel)
    handles = [h for h in axes[0].get_legend_handles_labels()[0]]
    if len(dims) > 1:
        handles.append(Patch(color="0.5", alpha=BAND["alpha"], label="shaded: range over the other swept axes"))
    return handles


def _first_text(values) -> str:
    """The first value of a swept axis as ``--select`` takes it: a label, or a number ('inf' for inf)."""
    if np.asarray(values).dtype.kind in "USO":
        return str(values[0])
    return value_text(float(values[0])).replace(chr(0x221e), "inf")


def select_hint(ds) -> str:
    """How to draw one slice of this cube: a ``study plot --select`` example of its first values."""
    dims = swept(ds)
    first = ",".join(f"{d}={_first_text(ds[d].values)}" for d in dims)
    return f"one slice as a map: study plot FILE --select {first}" if dims else ""
