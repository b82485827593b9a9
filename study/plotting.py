"""Plot helpers shared by the studies: figures without pyplot, the (beta0, omega30) plane,
labels placed inside connected regions. Drawing only; saving is ``study.io.write_figure``.
"""

from __future__ import annotations

import numpy as np
from matplotlib.figure import Figure
from scipy import ndimage

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


def beta_omega_axes(ax, ds, title: str) -> None:
    """beta0 on x in [-pi, pi) with ticks at multiples of pi/2; omega30 on y; units in labels."""
    ax.set_xlim(-np.pi, np.pi)
    w = ds["omega30"].values
    ax.set_ylim(w.min(), w.max())
    ax.set_xticks(PI_TICKS, PI_LABELS)
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


def components(mask: np.ndarray, min_fraction: float = 0.002, cells=None):
    """Connected parts of a boolean (omega30, beta0) mask, largest first, as boolean masks.

    Parts smaller than ``min_fraction`` of the grid are dropped. ``cells``: optional list of
    boolean masks; parts are then found within each cell separately.
    """
    parts = []
    for cell in cells if cells is not None else [np.ones_like(mask, dtype=bool)]:
        labels, n = ndimage.label(mask & cell)
        parts += [labels == k for k in range(1, n + 1)]
    parts = [m for m in parts if m.sum() >= min_fraction * mask.size]
    return sorted(parts, key=lambda m: -m.sum())


def inner_point(beta0, omega30, mask: np.ndarray) -> tuple[float, float]:
    """A point of ``mask`` deep inside it (the maximum of the distance to its edge) [rad, 1/s]."""
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
