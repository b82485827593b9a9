"""Boundary curves of an outcome grid: polylines between the regions of different outcome.

An outcome section (Figs. 11-13) is a 2-D grid of cells, each with one outcome code; drawn cell
by cell, the boundary between two outcomes is a staircase of cell edges. :func:`trace` replaces
it by polylines, marching-squares fashion, on the lattice of cell centres:

- a **link** joins two 4-neighbouring cells; it lies on a boundary when their codes differ, and
  the boundary crosses it at its midpoint (the midpoint of the cell edge between the two cells);
- a **square** of four neighbouring cell centres with two differing links is crossed by one
  straight segment between their midpoints (a corner cell cut off diagonally, or a straight run:
  the staircase smoothed at sub-cell level); one with three or four differing links (three or
  four outcomes meet, or a checkerboard of two) is a **junction**: each link's midpoint is joined
  to the square's centre;
- a differing link on the grid's edge is continued half a cell outward, to the edge of the
  region the cells cover;
- the pieces are joined into polylines wherever exactly two pieces of the same key meet; a
  polyline ends at a junction, at the grid's edge, or where the key changes (half-way between
  two link midpoints). The key of a piece is the pair of codes it separates and its link type
  (e.g. the type of the boundary of periodic rolling, :func:`link_types`).

So every differing link's midpoint is a vertex of exactly one polyline, and every segment lies
in a square (or border half-cell) whose cells do not all share one code: the polylines separate
exactly the cells of different code and cross no uniform region. A polyline that returns to its
start is closed (first point = last point). Points are in grid index units (row, column: a
cell's centre at integers, edges at half-integers); :func:`on_axes` maps them onto the grid's
coordinates. Pure numpy.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from rimroll.solver.analysis import boundaries
from rimroll.solver.engine import outcomes


@dataclass(frozen=True)
class Curves:
    """Polylines of :func:`trace`, as a contiguous ragged array.

    ``points`` (n_points, 2) float: (row, column) in grid index units, the curves one after the
    other; ``sizes`` (n_curves,) int: points of each curve (>= 2); ``code_a`` < ``code_b``
    (n_curves,): the two codes the curve separates; ``link_type`` (n_curves,) int8: the type of
    its links (0 where none was given)."""

    points: np.ndarray
    sizes: np.ndarray
    code_a: np.ndarray
    code_b: np.ndarray
    link_type: np.ndarray

    def __len__(self) -> int:
        return int(self.sizes.size)

    def curve(self, k: int) -> np.ndarray:
        """Points (size, 2) of curve ``k``."""
        start = int(self.sizes[:k].sum())
        return self.points[start:start + int(self.sizes[k])]


def _links(codes: np.ndarray):
    """Which links differ, along columns (cells (i, j), (i, j+1)) and along rows (cells (i, j),
    (i+1, j)), and the grid's shape."""
    n, m = codes.shape
    along_cols = codes[:, :-1] != codes[:, 1:]
    along_rows = codes[:-1, :] != codes[1:, :]
    return along_cols, along_rows, n, m


def trace(codes, link_type=None) -> Curves:
    """Polylines between the cells of different code of a 2-D grid (see the module docstring).

    Parameters
    ----------
    codes : int array (n_rows, n_cols)
        One code per cell (e.g. ``outcome``).
    link_type : (array (n_rows, n_cols - 1), array (n_rows - 1, n_cols)), optional
        An integer type of each link along columns and along rows (e.g. :func:`link_types`),
        part of the key that splits the polylines; default 0.

    Returns
    -------
    :class:`Curves`, points in grid index units.
    """
    codes = np.asarray(codes)
    if codes.ndim != 2 or codes.size == 0:
        raise ValueError(f"trace needs a non-empty 2-D grid of codes; got shape {codes.shape}")
    cols, rows, n, m = _links(codes)
    if link_type is None:
        link_type = (np.zeros(cols.shape, np.int8), np.zeros(rows.shape, np.int8))
    t_cols, t_rows = (np.asarray(t) for t in link_type)
    if t_cols.shape != cols.shape or t_rows.shape != rows.shape:
        raise ValueError(f"link_type must have shapes {cols.shape} and {rows.shape}; got {t_cols.shape} and "
                         f"{t_rows.shape}")
    n_sq_c = max(m - 1, 0)
    # the squares a boundary crosses (two or more differing links: bottom = row i, top = row i + 1,
    # left = column j, right = column j + 1), numbered in the order of their flat index
    if n > 1 and m > 1:
        b, t, lft, r = (x.astype(np.int8) for x in (cols[:-1, :], cols[1:, :], rows[:, :-1], rows[:, 1:]))
        active = np.flatnonzero((b + t + lft + r).ravel() >= 2)
        b, t, lft, r = (x.ravel()[active].astype(float) for x in (b, t, lft, r))
        ii, jj = (active // n_sq_c).astype(float), (active % n_sq_c).astype(float)
        two = (b + t + lft + r) == 2  # the midpoint of the two link midpoints; else the square's centre
        sq_pos = np.stack([np.where(two, (b * ii + t * (ii + 1) + (lft + r) * (ii + 0.5)) / 2, ii + 0.5),
                           np.where(two, ((b + t) * (jj + 0.5) + lft * jj + r * (jj + 1)) / 2, jj + 0.5)], 1)
    else:
        active, sq_pos = np.zeros(0, np.int64), np.zeros((0, 2))
    n_sq = active.size

    def square(i, j):
        return np.searchsorted(active, i * n_sq_c + j)

    # pieces: one per differing link, from the node on one side through the link's midpoint to the other
    ci, cj = np.nonzero(cols)
    ri, rj = np.nonzero(rows)
    n_pieces = ci.size + ri.size
    mids = np.concatenate([np.stack([ci, cj + 0.5], 1), np.stack([ri + 0.5, rj.astype(float)], 1)]).reshape(-1, 2)
    key_a = np.concatenate([np.minimum(codes[ci, cj], codes[ci, cj + 1]), np.minimum(codes[ri, rj], codes[ri + 1, rj])])
    key_b = np.concatenate([np.maximum(codes[ci, cj], codes[ci, cj + 1]), np.maximum(codes[ri, rj], codes[ri + 1, rj])])
    key_t = np.concatenate([t_cols[ci, cj], t_rows[ri, rj]]).astype(np.int64)
    border = n_sq + np.arange(2 * n_pieces)  # each piece may own two border nodes (used where it meets the edge)
    # the two ends: squares below/above a column link, left/right of a row link, else a border node
    below = np.where(ci >= 1, square(ci - 1, cj), border[:ci.size])
    above = np.where(ci <= n - 2, square(ci, cj), border[n_pieces:n_pieces + ci.size])
    left = np.where(rj >= 1, square(ri, rj - 1), border[ci.size:n_pieces])
    right = np.where(rj <= m - 2, square(ri, rj), border[n_pieces + ci.size:])
    end0 = np.concatenate([below, left]).astype(np.int64)
    end1 = np.concatenate([above, right]).astype(np.int64)
    out = np.concatenate([np.tile([[0.5, 0.0]], (ci.size, 1)), np.tile([[0.0, 0.5]], (ri.size, 1))]).reshape(-1, 2)
    pos = np.concatenate([sq_pos, mids - out, mids + out])
    return _join(mids, end0, end1, pos, key_a, key_b, key_t)


def _join(mids, end0, end1, pos, key_a, key_b, key_t) -> Curves:
    """Chain the pieces (link midpoint ``mids`` between nodes ``end0`` and ``end1``) into polylines
    through every node where exactly two pieces of one key meet."""
    n_pieces = mids.shape[0]
    at = {}  # node -> pieces ending there
    for p, (u, w) in enumerate(zip(end0.tolist(), end1.tolist())):
        at.setdefault(u, []).append(p)
        at.setdefault(w, []).append(p)
    key = list(zip(key_a.tolist(), key_b.tolist(), key_t.tolist()))

    def through(node) -> bool:
        ps = at[node]
        return len(ps) == 2 and key[ps[0]] == key[ps[1]]

    e0, e1 = end0.tolist(), end1.tolist()
    mid = mids.tolist()
    seen = [False] * n_pieces
    curves, owners = [], []

    def walk(p, node, closed):
        pts = [] if closed else [pos[node].tolist()]
        first = p
        while True:
            seen[p] = True
            pts.append(mid[p])
            node = e1[p] if e0[p] == node else e0[p]
            if not through(node):
                pts.append(pos[node].tolist())
                break
            a, b = at[node]
            p = b if a == p else a
            if p == first:  # back at the start: a closed curve
                pts.append(pts[0])
                break
        curves.append(pts)
        owners.append(first)

    for p in range(n_pieces):
        if seen[p]:
            continue
        if not through(e0[p]):
            walk(p, e0[p], False)
        elif not through(e1[p]):
            walk(p, e1[p], False)
    for p in range(n_pieces):  # what is left runs through joining nodes only: closed curves
        if not seen[p]:
            walk(p, e0[p], True)
    sizes = np.array([len(c) for c in curves], dtype=np.int64)
    points = np.array([pt for c in curves for pt in c], dtype=float).reshape(-1, 2)
    owners = np.array(owners, dtype=np.int64)
    return Curves(points, sizes, key_a[owners] if owners.size else key_a[:0], key_b[owners] if owners.size
                  else key_b[:0], key_t[owners].astype(np.int8))


def on_axes(points, rows, cols) -> tuple[np.ndarray, np.ndarray]:
    """The grid coordinates of points in index units: (row values, column values), each axis
    interpolated linearly between its grid points and extended by its end spacing (half a cell
    beyond the last point; a 1-point axis: +-0.5 per cell, as ``study.plotting.grid_limits``)."""
    points = np.asarray(points, dtype=float).reshape(-1, 2)
    return _along(points[:, 0], np.asarray(rows, float)), _along(points[:, 1], np.asarray(cols, float))


def _along(f, axis):
    if axis.size == 1:
        return axis[0] + f
    idx = np.arange(axis.size)
    out = np.interp(f, idx, axis)
    lo, hi = f < 0, f > axis.size - 1
    out[lo] = axis[0] + f[lo] * (axis[1] - axis[0])
    out[hi] = axis[-1] + (f[hi] - axis.size + 1) * (axis[-1] - axis[-2])
    return out


def link_types(outcome, cell_type) -> tuple[np.ndarray, np.ndarray]:
    """The boundary type of every link of an outcome grid (for :func:`trace`), from the cells' types.

    ``outcome``, ``cell_type``: (n_beta, n_omega1) codes of ``solver.engine.outcomes`` and of
    ``boundaries.BOUNDARY_MEANINGS`` (e.g. ``boundary_type``). A link between a periodic cell and
    one that falls or is still on the rim at t_max lies on a boundary of periodic rolling: it
    takes the type both cells have, or where they differ the one later in the priority order of
    :func:`boundaries.classify` (a cell shows the first type of all its pairs, so the later one is
    the nearer to this pair's own; a cell typed ``not_boundary`` gives way). Every other link:
    ``not_boundary``. Returns the types of the
    links along columns (n_beta, n_omega1 - 1) and along rows (n_beta - 1, n_omega1), int8.
    """
    outcome, cell_type = np.asarray(outcome), np.asarray(cell_type)
    if outcome.shape != cell_type.shape or outcome.ndim != 2:
        raise ValueError(f"outcome and cell_type must be 2-D of one shape; got {outcome.shape} and {cell_type.shape}")
    periodic = outcome == outcomes.PERIODIC_ROLLING
    other = np.isin(outcome, (outcomes.FALL_IN, outcomes.FALL_OUT, outcomes.ON_RIM_AT_T_MAX))
    rank = np.full(max(boundaries.BOUNDARY_FLAG_VALUES) + 1, -1, dtype=np.int64)
    for position, code in enumerate(boundaries.PRIORITY):
        rank[code] = position
    out = []
    for lo, hi in (((slice(None), slice(None, -1)), (slice(None), slice(1, None))),
                   ((slice(None, -1), slice(None)), (slice(1, None), slice(None)))):
        pair = (periodic[lo] & other[hi]) | (other[lo] & periodic[hi])
        t1, t2 = cell_type[lo], cell_type[hi]
        later = np.where(rank[t1] >= rank[t2], t1, t2)
        out.append(np.where(pair, later, boundaries.NOT_BOUNDARY).astype(np.int8))
    return out[0], out[1]
