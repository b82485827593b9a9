"""Plot helpers shared by the studies: figures without pyplot, the (beta0, omega30) plane,
labels placed inside connected regions. Drawing only; saving is ``study.io.write_figure``.
"""

from __future__ import annotations

import numpy as np
from matplotlib.figure import Figure

from rimroll.solver.engine import scenes

PI_TICKS = np.arange(-2, 3) * np.pi / 2
PI_LABELS = [r"$-\pi$", r"$-\pi/2$", r"$0$", r"$\pi/2$", r"$\pi$"]


def new_figure(width: float = 7.5, height: float = 5.5):
    """A (Figure, Axes) pair built without pyplot (thread-safe, no global state)."""
    fig = Figure(figsize=(width, height), layout="constrained")
    return fig, fig.add_subplot()


def plane(ds, name: str) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(beta0 [rad], omega30 [1/s], values) with values shaped (omega30, beta0) for pcolormesh/contour.

    beta0 is an angle: when the grid is [-pi, pi) its first column is repeated at +pi so that
    pictures reach the right edge without a gap.
    """
    b = ds["beta0"].values
    v = ds[name].transpose("omega30", "beta0").values
    if np.isclose(b[0], -np.pi) and b[-1] < np.pi:
        b = np.append(b, np.pi)
        v = np.concatenate([v, v[:, :1]], axis=1)
    return b, ds["omega30"].values, v


def refined_plane(ds, fn, points: int = 1200) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(beta0, omega30, values) of a closed-form map ``fn(beta0, omega30)`` on a grid finer than the
    file's (about ``points`` per axis, the file's domain), shaped like :func:`plane`'s: a contour that
    encloses a few grid cells of the file (a small lobe near a singular point) is drawn as a curve,
    not as a speck. For maps whose values are closed forms of (beta0, omega30) only (``solver.steady``)."""
    b, w = ds["beta0"].values, ds["omega30"].values
    b_hi = np.pi if np.isclose(b[0], -np.pi) and b[-1] < np.pi else b.max()
    bf = np.linspace(b.min(), b_hi, max(points, b.size))
    wf = np.linspace(w.min(), w.max(), max(points, w.size))
    B, W = np.meshgrid(bf, wf)
    with np.errstate(all="ignore"):
        return bf, wf, np.asarray(fn(B, W), dtype=float)


def beta_omega_axes(ax, ds, title: str) -> None:
    """beta0 on x, omega30 on y, each over the computed domain only (a restricted grid is not
    padded with an uncomputed area that would read as a region); ticks at multiples of pi/2
    when the domain holds at least two of them; units in labels."""
    b, w = ds["beta0"].values, ds["omega30"].values
    b_hi = np.pi if np.isclose(b[0], -np.pi) and b[-1] < np.pi else b.max()  # plane() closes the circle
    ax.set_xlim(b.min(), b_hi)
    ax.set_ylim(w.min(), w.max())
    inside = (PI_TICKS >= b.min() - 1e-9) & (PI_TICKS <= b_hi + 1e-9)
    if inside.sum() >= 2:
        ax.set_xticks(PI_TICKS[inside], [lbl for lbl, ok in zip(PI_LABELS, inside) if ok])
    ax.set_xlabel(r"height angle $\beta_0$ [rad]")
    ax.set_ylabel(r"circular angular velocity $\omega_{30}$ [1/s]")
    ax.set_title(title, fontsize=11)


def singular_lines(ax, circles: bool = True) -> None:
    """The singular lines beta0 = +-pi/2 and omega30 = 0 of (48), thick; circles where they meet."""
    for b in (-np.pi / 2, np.pi / 2):
        ax.axvline(b, color="k", lw=2.2, zorder=5)
    ax.axhline(0.0, color="k", lw=2.2, zorder=5)
    if circles:
        ax.plot([-np.pi / 2, np.pi / 2], [0, 0], "o", ms=9, mfc="white", mec="k", mew=1.8, zorder=6)


def singular_polylines(ax, n: int = 400) -> list:
    """The singular lines of :func:`singular_lines` as sampled polylines (data coordinates) across the
    axes' limits, for label placement to keep off."""
    (x0, x1), (y0, y1) = ax.get_xlim(), ax.get_ylim()
    ys, xs = np.linspace(y0, y1, n), np.linspace(x0, x1, n)
    return [np.column_stack([np.full(n, b), ys]) for b in (-np.pi / 2, np.pi / 2)] + [
        np.column_stack([xs, np.zeros(n)])]


def components(mask: np.ndarray, min_fraction: float = 0.002, cells=None):
    """Connected parts of a boolean (omega30, beta0) mask, largest first, as boolean masks.

    Parts smaller than ``min_fraction`` of the grid are dropped. ``cells``: optional list of
    boolean masks; parts are then found within each cell separately.
    """
    from scipy import ndimage  # here, not at the top: its import costs ~0.25 s and most plots never need it

    parts = []
    for cell in cells if cells is not None else [np.ones_like(mask, dtype=bool)]:
        labels, n = ndimage.label(mask & cell)
        parts += [labels == k for k in range(1, n + 1)]
    parts = [m for m in parts if m.sum() >= min_fraction * mask.size]
    return sorted(parts, key=lambda m: -m.sum())


def inner_point(beta0, omega30, mask: np.ndarray) -> tuple[float, float]:
    """A point of ``mask`` deep inside it (the maximum of the distance to its edge) [rad, 1/s]."""
    from scipy import ndimage  # here, not at the top: see components

    depth = ndimage.distance_transform_edt(np.pad(mask, 1))[1:-1, 1:-1]
    i, j = np.unravel_index(np.argmax(depth), depth.shape)
    return float(beta0[j]), float(omega30[i])


def branch_cells(beta0, omega30) -> list[np.ndarray]:
    """The plane cut by the singular lines beta0 = +-pi/2 and omega30 = 0: six (omega30, beta0) masks."""
    B, W = np.meshgrid(beta0, omega30)
    bands = [B < -np.pi / 2, (B > -np.pi / 2) & (B < np.pi / 2), B > np.pi / 2]
    return [band & side for band in bands for side in (W > 0, W < 0)]


def label_parts(ax, beta0, omega30, mask, text: str, min_fraction: float = 0.002, split=False, **kw) -> list:
    """Write ``text`` inside every connected part of ``mask``; returns the points used.

    ``split``: treat the singular lines as boundaries (one label per branch piece).
    """
    style = dict(ha="center", va="center", fontsize=15, fontweight="bold", zorder=7)
    style.update(kw)
    points = []
    cells = branch_cells(beta0, omega30) if split else None
    for part in components(mask, min_fraction, cells):
        x, y = inner_point(beta0, omega30, part)
        ax.text(x, y, text, **style)
        points.append((x, y))
    return points


# ---------------------------------------------------------------- labels of regions: inside when they fit
def _text_size(ax, text: str, fontsize: float) -> tuple[float, float]:
    """(width, height) of a bold label in axes fractions (an estimate from the axes' size before layout)."""
    pixels = ax.figure.dpi / 72.0  # per point
    return ((0.62 * fontsize * len(text) + 6) * pixels / ax.bbox.width, (1.3 * fontsize + 6) * pixels / ax.bbox.height)


def _cells_in(x, y, box_data) -> tuple[np.ndarray, np.ndarray]:
    """Rows (y) and columns (x) of the grid points inside a data box (x0, x1, y0, y1)."""
    x0, x1, y0, y1 = box_data
    return np.flatnonzero((y >= y0) & (y <= y1)), np.flatnonzero((x >= x0) & (x <= x1))


def place_labels(ax, x, y, pieces, occupied, fontsize: float = 15, walls=((), ())) -> list:
    """Write each ``(text, mask)`` of ``pieces`` (masks over (y, x) grid points) inside its piece where
    the text fits there, else next to it in a free place with a thin leader into the piece. A free
    place lies inside the axes, on no grid point of ``occupied``, across none of the lines
    ``walls`` = (x values, y values) and on no other label. Call after the axes' limits are final.
    Returns the Text objects."""
    to_axes = ax.transData + ax.transAxes.inverted()
    placed, texts = [], []
    style = dict(ha="center", va="center", fontweight="bold", zorder=7)

    def box_of(centre, size):
        return np.array([centre[0] - size[0] / 2, centre[0] + size[0] / 2, centre[1] - size[1] / 2,
                         centre[1] + size[1] / 2])

    def data_box(box):
        (x0, y0), (x1, y1) = to_axes.inverted().transform([(box[0], box[2]), (box[1], box[3])])
        return min(x0, x1), max(x0, x1), min(y0, y1), max(y0, y1)

    def clear(box, mask, inside):
        if inside and not (box[0] >= 0 and box[1] <= 1 and box[2] >= 0 and box[3] <= 1):
            return False
        if any(b[0] < box[1] and box[0] < b[1] and b[2] < box[3] and box[2] < b[3] for b in placed):
            return False
        x0, x1, y0, y1 = data_box(box)
        if any(x0 < v < x1 for v in walls[0]) or any(y0 < v < y1 for v in walls[1]):
            return False
        rows, cols = _cells_in(x, y, (x0, x1, y0, y1))
        return not rows.size or not cols.size or not mask[np.ix_(rows, cols)].any()

    for text, piece in pieces:
        point = to_axes.transform(inner_point(x, y, piece))
        size = _text_size(ax, text, fontsize)
        if clear(box_of(point, size), ~piece, inside=True):
            texts.append(ax.text(*to_axes.inverted().transform(point), text, fontsize=fontsize,
                                 bbox=dict(fc="white", ec="none", alpha=0.6, pad=0.5), **style))
            placed.append(box_of(point, size))
            continue
        small = (size[0] * 0.8, size[1] * 0.8)
        spots = [point + r * np.array([np.cos(a), np.sin(a)]) for r in (0.07, 0.1, 0.14, 0.19, 0.25)
                 for a in np.linspace(0, 2 * np.pi, 16, endpoint=False)]
        spot = next((c for c in spots if clear(box_of(c, small), occupied, inside=True)), None)
        if spot is None:  # nowhere free: inside after all, smaller
            texts.append(ax.text(*to_axes.inverted().transform(point), text, fontsize=0.7 * fontsize, **style))
            continue
        texts.append(ax.annotate(text, to_axes.inverted().transform(point), xytext=tuple(spot),
                                 textcoords="axes fraction", fontsize=0.8 * fontsize,
                                 arrowprops=dict(arrowstyle="-", lw=0.9, color="k", shrinkA=0, shrinkB=0),
                                 bbox=dict(fc="white", ec="none", alpha=0.8, pad=0.3), **style))
        placed.append(box_of(spot, small))
    return texts


# ---------------------------------------------------------------- Fig. 8: the realisable regions
REGION_COLOURS = {1: "#9ecae1", 2: "#fdd0a2", 3: "#c7e9c0"}
"""Fill of the realisable regions A, B, C (codes of ``solver.steady.REGION_*``) in every region map."""
REGION_LINE_COLOURS = {1: "#3182bd", 2: "#e6550d", 3: "#31a354"}
"""The same regions as lines and markers (areas against a swept setting)."""


def region_pieces(b, w, region, w20, letters, min_fraction: float = 0.001) -> list:
    """``(text, mask)`` of every connected piece of each (region, sign of omega20): "A+", "B−", ...
    Pieces smaller than ``min_fraction`` of the grid are left out, but the largest of each pair
    (region, sign) that occurs is always kept; region A holds both signs (paper Sect. 3)."""
    from rimroll.solver.analysis import steady

    out = []
    for code in (steady.REGION_A, steady.REGION_B, steady.REGION_C):
        for sign, text in ((1, "+"), (-1, "\u2212")):
            pieces = components((region == code) & (np.sign(w20) == sign), min_fraction=0.0)
            keep = pieces[:1] + [m for m in pieces[1:] if m.sum() >= min_fraction * m.size]
            out += [(letters[code][0] + text, m) for m in keep]
    return out


def region_map(ax, b, w, region, w20, letters, fontsize: float = 15) -> list:
    """Fig. 8 on ``ax``: the realisable regions (``region`` codes over (omega30, beta0)), each (region,
    sign of omega20) piece labelled, omega20 = 0 dotted inside the regions, the singular lines.
    ``b``, ``w``: the grid [rad, 1/s] (``plane``); call after the axes' limits are set. Returns the labels."""
    from rimroll.solver.analysis import steady

    for code, colour in REGION_COLOURS.items():
        ax.contourf(b, w, (region == code).astype(float), levels=[0.5, 1.5], colors=[colour])
        ax.contour(b, w, (region == code).astype(float), levels=[0.5], colors="0.35", linewidths=0.8)
    inside = region != steady.REGION_NONE
    if (np.nanmin(np.where(inside, w20, np.inf)) < 0) and (np.nanmax(np.where(inside, w20, -np.inf)) > 0):
        ax.contour(b, w, np.where(inside, w20, np.nan), levels=[0.0], colors="k", linestyles=":", linewidths=1.8)
    singular_lines(ax, circles=False)
    pieces = region_pieces(b, w, region, w20, letters)
    return place_labels(ax, b, w, pieces, inside, fontsize=fontsize, walls=((-np.pi / 2, np.pi / 2), (0.0,)))


# ---------------------------------------------------------------- outcomes: one palette, one set of labels
OUTCOME_TEXT = {  # reader-facing words for the outcome codes' flag meanings
    "fall_in": "falls in (score)",
    "fall_out": "falls out",
    "periodic_rolling": "periodic rolling",
    "on_rim_at_t_max": r"on the rim at $t_{max}$",
    "steady_motion": "steady motion (exact)",
}
OUTCOME_COLOUR = {
    "fall_in": "#2b8cbe",  # blue
    "fall_out": "#e6550d",  # orange
    "periodic_rolling": "#31a354",  # green
    "on_rim_at_t_max": "#bdbdbd",  # light grey
    "steady_motion": "#756bb1",  # purple
}
_FALLBACK_COLOURS = ("#e7298a", "#66a61e", "#a6761d", "#1b9e77", "#666666")


class OutcomePalette:
    """Colours and reader-facing labels of the outcome codes, from ``solver.OUTCOME_MEANINGS``.

    One object, used by every outcome figure (fig11-13, outcome-cube), so a colour means the
    same outcome everywhere. Codes the palette has no word for (a code added to the engine
    later) get their flag meaning with spaces and a colour of a fallback list.
    """

    def __init__(self, meanings: dict):
        self.codes = tuple(int(c) for c in meanings)
        names = [str(m).split(":")[0].strip() for m in meanings.values()]
        spare = iter(_FALLBACK_COLOURS * (1 + len(names) // len(_FALLBACK_COLOURS)))
        self.names = dict(zip(self.codes, names))
        self.colours = {c: OUTCOME_COLOUR.get(n) or next(spare) for c, n in self.names.items()}
        self.labels = {c: OUTCOME_TEXT.get(n, n.replace("_", " ")) for c, n in self.names.items()}

    def colour(self, code: int) -> str:
        """Colour of an outcome code (a neutral grey for a code the palette does not know)."""
        return self.colours.get(int(code), "0.5")

    def label(self, code: int) -> str:
        """Reader-facing label of an outcome code ("outcome <code>" for an unknown one)."""
        return self.labels.get(int(code), f"outcome {int(code)}")

    def cmap_norm(self):
        """(ListedColormap, BoundaryNorm) mapping each code 0..max to its colour, for pcolormesh."""
        from matplotlib.colors import BoundaryNorm, ListedColormap

        top = max(self.codes)
        cmap = ListedColormap([self.colour(c) for c in range(top + 1)])
        return cmap, BoundaryNorm(np.arange(-0.5, top + 1.5), cmap.N)

    def handles(self, codes=None) -> list:
        """Legend patches of ``codes`` (default: every known code), in code order."""
        from matplotlib.patches import Patch

        codes = self.codes if codes is None else sorted(int(c) for c in codes)
        return [Patch(color=self.colour(c), label=self.label(c)) for c in codes]


def _outcome_palette() -> OutcomePalette:
    from rimroll import solver
    return OutcomePalette(solver.OUTCOME_MEANINGS)


OUTCOME_PALETTE = _outcome_palette()
"""The palette of every outcome figure (fig11-13, outcome-cube)."""


STAR = dict(marker="*", ls="", ms=11, mfc="none", mec="k", mew=1.3, zorder=5)
"""The steady motion (48) in an outcome map: hollow, so the cells show through."""


def outcome_map(ax, w1, beta, codes, b0=None, star_size=None) -> set:
    """An outcome section on ``ax``: the codes (beta, omega1) in the outcome palette, the axes over the
    grid's cells, the steady motion at (0, ``b0``) as a star when it lies inside; returns the codes drawn."""
    cmap, norm = OUTCOME_PALETTE.cmap_norm()
    ax.pcolormesh(w1, beta, codes, cmap=cmap, norm=norm, shading="nearest", rasterized=True)
    ax.set_xlim(*grid_limits(w1))
    ax.set_ylim(*grid_limits(beta))
    if b0 is not None and beta.min() <= b0 <= beta.max() and w1.min() <= 0.0 <= w1.max():
        ax.plot([0.0], [b0], **(STAR if star_size is None else dict(STAR, ms=star_size, mew=1.0)))
    return set(np.unique(codes).tolist())


TIME_LEVELS = (5.0, 20.0)  # [s] contours of the time on the rim in dissipative panels (white, labelled)
LONG_TIME = 10.0  # [s] a dotted area: on the rim at least this long (the paper's dotted regions, Fig. 11)
TIME_STYLE = dict(colors="white", linewidths=0.9, linestyles="-")


def time_on_rim(ax, w1, beta, t_end, t_max: float, b0=None, labels: bool = True) -> dict:
    """How long a dissipative scene keeps the ball on the rim, on an outcome map: white contours of
    ``t_end`` (beta, omega1) [s] at :data:`TIME_LEVELS` below ``t_max`` (labelled clear of the star at
    (0, ``b0``); a level crowding it is named by the legend only), and the states on the rim for
    :data:`LONG_TIME` or longer dotted, as the paper dots them. Returns legend handles by key."""
    from matplotlib.lines import Line2D
    from matplotlib.patches import Patch

    out = {}
    levels = [lv for lv in TIME_LEVELS if lv < t_max and np.nanmin(t_end) < lv < np.nanmax(t_end)]
    if levels:
        cs = ax.contour(w1, beta, t_end, levels=levels, zorder=4.5, **TIME_STYLE)
        if labels:
            place_contour_labels(ax, cs, fmt="%g s", clear=0.09, avoid=[(0.0, b0)] if b0 is not None else [],
                                 crowded="skip")
        from matplotlib import patheffects

        outline = [patheffects.Stroke(linewidth=3.2, foreground="0.25"), patheffects.Normal()]
        out["time"] = Line2D([], [], color=TIME_STYLE["colors"], lw=1.6, path_effects=outline,  # white, as drawn
                             label=r"time on the rim, white lines: "
                             + ", ".join(f"{lv:g}" for lv in TIME_LEVELS) + " s")
    if np.nanmax(t_end) >= LONG_TIME:
        ax.contourf(w1, beta, np.nan_to_num(t_end, nan=0.0), levels=[LONG_TIME, np.nanmax(t_end) + 1.0],
                    colors="none", hatches=[".."], zorder=4.2)
        out["long"] = Patch(fc="none", ec="k", lw=0.0, hatch="..", label=f"on the rim {LONG_TIME:g} s or longer")
    return out


# ---------------------------------------------------------------- scenes of the outcome sections
SCENE_KEYS = tuple(s.name for s in scenes.NAMED)
"""Labels of the ``scene`` dimension (``solver.engine.scenes.NAMED``); files written before the labels
were strings hold 0..3."""


def scene_key(value) -> str:
    """The scene label of a ``scene`` coordinate value: a string label, or an old numeric code 0..3."""
    if isinstance(value, bytes):
        value = value.decode()
    if isinstance(value, str):
        return value
    k = int(round(float(value)))
    return SCENE_KEYS[k] if 0 <= k < len(SCENE_KEYS) else f"scene_{k}"


def scene_text(value) -> str:
    """Reader-facing name of a scene (label or old numeric code)."""
    try:
        return scenes.named(scene_key(value)).text
    except ValueError:
        return scene_key(value).replace("_", " ")


def scene_title(sel) -> str:
    """Panel title of one scene of an outcome file: its name and the mu, k_d, k_r it models."""
    mu = float(sel["mu"]) if "mu" in sel.coords else np.nan
    k_r = float(sel["k_r"]) if "k_r" in sel.coords else 0.0
    k_d = float(sel["k_d"]) if "k_d" in sel.coords else 0.0
    mu_txt = r"$\mu=\infty$" if np.isinf(mu) else (rf"$\mu={mu:g}$" if np.isfinite(mu) else "")
    extra = (rf", $k_d={k_d:g}$ 1/s" if k_d else "") + (rf", $k_r={k_r:g}$ 1/s" if k_r else "")
    return f"{scene_text(sel['scene'].values[()])} ({mu_txt}{extra})"


# ---------------------------------------------------------------- legends and limits
def legend_texts(fig) -> list[str]:
    """Texts of every legend of ``fig`` (figure and axes legends), in order."""
    legends = list(fig.legends) + [ax.get_legend() for ax in fig.axes if ax.get_legend() is not None]
    return [t.get_text() for leg in legends for t in leg.get_texts()]


def grid_limits(values) -> tuple[float, float]:
    """(lo, hi) of the cells around a 1-D grid (half a spacing beyond each end; one point: +-0.5)."""
    v = np.sort(np.asarray(values, dtype=float))
    if v.size < 2:
        return float(v[0]) - 0.5, float(v[0]) + 0.5
    return float(v[0] - 0.5 * (v[1] - v[0])), float(v[-1] + 0.5 * (v[-1] - v[-2]))


# ---------------------------------------------------------------- contour labels clear of markers
def _beside(cand, order, own, blocking, size) -> np.ndarray | None:
    """Centre (axes fractions) of a label of ``size`` next to its line: at the first point of ``cand``
    (in the order ``order``) where one of the two spots off the line along its normal, half the
    label's diagonal away, holds no point of ``blocking`` (every line, this one included) and lies
    inside the axes; None if there is no such spot."""
    pad = 0.004
    for point in cand[order]:
        d = np.hypot(*(own - point).T)
        near = own[(d > 0) & (d < 0.03)]
        tangent = (near[np.argmax(np.hypot(*(near - point).T))] - point) if near.size else np.array([1.0, 0.0])
        tangent = tangent / (np.hypot(*tangent) or 1.0)
        normal = np.array([-tangent[1], tangent[0]])
        for side in (1, -1):
            spot = point + side * (0.5 * np.hypot(*size) + 0.006) * normal
            lo, hi = spot - np.asarray(size) / 2 - pad, spot + np.asarray(size) / 2 + pad
            if np.any(lo < 0) or np.any(hi > 1):
                continue
            if not np.any(np.all((blocking >= lo) & (blocking <= hi), axis=1)):
                return spot
    return None


def place_contour_labels(ax, cs, fmt, avoid=(), fontsize: float = 7.5, margin: float = 0.05,
                         clear: float = 0.05, inline: bool = True, beside: bool = False, walls=(),
                         crowded: str = "leader") -> list:
    """Label each level of the contour set ``cs`` once, at the point of its line farthest from
    everything else: the points ``avoid`` (data coordinates, e.g. a marker), the other levels'
    lines and the labels already placed; never within ``margin`` (axes fraction) of an edge.

    Call after the axes' limits are final. A level whose every point lies within ``clear`` (axes
    fraction) of a point to avoid or of a placed label is labelled outside, with a thin leader
    (``crowded="leader"``), or not at all (``crowded="skip"``: the legend names the levels).
    ``inline``: break the line under the label and give the label a light box; otherwise a
    white halo around the letters only (for lines that border a shading: no gap in it).
    ``beside``: the label is written next to its line, upright, where no line runs through it (the
    line stays whole), nor any of the polylines ``walls`` (data coordinates, e.g. singular lines).
    Returns the label Text objects.
    """
    from matplotlib import patheffects

    halo = [patheffects.withStroke(linewidth=2.5, foreground="white")]
    to_axes = ax.transData + ax.transAxes.inverted()
    avoid = [np.asarray(a, dtype=float).reshape(-1, 2) for a in avoid]
    lines = []
    for segs in cs.allsegs:
        pts = [s for s in segs if len(s)]
        line = to_axes.transform(np.concatenate(pts)) if pts else np.empty((0, 2))
        lines.append(line[:: max(1, len(line) // 800)])  # at most ~800 points a level: distances are pairwise
    fixed = [to_axes.transform(a) for a in avoid if a.size]
    blocking = [to_axes.transform(np.asarray(w, dtype=float).reshape(-1, 2)) for w in walls] or [np.empty((0, 2))]
    chosen = []
    texts = []
    for k, level in enumerate(cs.levels):
        cand = lines[k]
        inside = np.all((cand > margin) & (cand < 1 - margin), axis=1)
        if not inside.any():
            continue
        cand = cand[inside]
        def dist(points):  # distance in axes units, a label's own width counted along x
            # called in this iteration only: cand is this level's (B023 a false positive)
            if not points:
                return np.full(len(cand), np.inf)  # noqa: B023
            ref = np.concatenate(points)
            return np.min(np.hypot((cand[:, None, 0] - ref[None, :, 0]) / 1.6,  # noqa: B023
                                   cand[:, None, 1] - ref[None, :, 1]), axis=1)  # noqa: B023

        hard = dist(fixed + chosen)
        soft = np.minimum(hard, dist([lines[i] for i in range(len(lines)) if i != k and len(lines[i])]))
        ok = hard >= clear
        text = fmt % level if isinstance(fmt, str) else fmt(level)
        spot = None if not (ok.any() and beside) else _beside(
            cand[ok], np.argsort(-soft[ok]), lines[k], np.concatenate([*lines, *blocking]),
            _text_size(ax, text, fontsize * 0.8))
        if spot is not None:
            colours = cs.get_edgecolor()
            texts.append(ax.text(*spot, text, transform=ax.transAxes, fontsize=fontsize, ha="center", va="center",
                                 color=colours[k] if len(colours) > k else "k", path_effects=halo, zorder=8))
            chosen.append(spot[None, :])
            half = np.asarray(_text_size(ax, text, fontsize * 0.8)) / 2  # the next labels keep off this one
            blocking.append(spot + np.array([[0, 0], [-1, -1], [-1, 1], [1, -1], [1, 1]]) * half)
        elif ok.any() and not beside:
            best = cand[ok][int(np.argmax(soft[ok]))]
            xy = to_axes.inverted().transform(best)
            before = len(cs.labelTexts)
            ax.clabel(cs, levels=[level], manual=[tuple(xy)], inline=inline, fmt=fmt, fontsize=fontsize)
            new = cs.labelTexts[before:]
            if not new and len(cs.labelTexts) and cs.labelTexts[-1].get_text():
                new = cs.labelTexts[-1:]
            for t in new:
                if inline:
                    t.set_color("k")  # on its light box, whatever the line's colour
                    t.set_bbox(dict(fc="white", ec="none", alpha=0.75, pad=0.6))
                else:
                    t.set_path_effects(halo)
                texts.append(t)
            chosen.append(best[None, :])
        elif crowded == "skip":
            continue
        else:  # crowded: in the nearest free place, with a leader to the line's point farthest from the crowd
            anchor = cand[int(np.argmax(hard))]
            size = _text_size(ax, text, fontsize * 0.8)
            spot = _free_spot(anchor, size, np.concatenate([*lines, *blocking, *fixed, *chosen]))
            if spot is None:
                n_out = sum(1 for t in texts if getattr(t, "arrow_patch", None) is not None)
                spot = np.array([min(anchor[0] + 0.08, 1 - 3 * margin), min(anchor[1] + 0.05 + 0.05 * n_out, 0.95)])
            t = ax.annotate(text, to_axes.inverted().transform(anchor), xytext=tuple(spot),
                            textcoords="axes fraction", fontsize=fontsize, ha="center", va="center",
                            arrowprops=dict(arrowstyle="-", lw=0.6, color="k", shrinkA=0, shrinkB=0),
                            bbox=dict(fc="white", ec="none", alpha=0.75, pad=0.6), zorder=8)
            texts.append(t)
            chosen.append(spot[None, :])
            blocking.append(spot + np.array([[0, 0], [-1, -1], [-1, 1], [1, -1], [1, 1]]) * np.asarray(size) / 2)
    return texts


def _free_spot(anchor, size, blocking, radii=(0.06, 0.09, 0.12, 0.16, 0.21)) -> np.ndarray | None:
    """The nearest centre (axes fractions) around ``anchor`` of a label of ``size`` that holds no point
    of ``blocking`` and lies inside the axes; None if there is none."""
    half = np.asarray(size) / 2 + 0.004
    for r in radii:
        for a in np.linspace(np.pi / 4, np.pi / 4 + 2 * np.pi, 16, endpoint=False):
            spot = anchor + r * np.array([np.cos(a), np.sin(a)])
            lo, hi = spot - half, spot + half
            if np.all(lo >= 0) and np.all(hi <= 1) and not np.any(np.all((blocking >= lo) & (blocking <= hi), axis=1)):
                return spot
    return None
