"""Boundaries of an outcome section located exactly on every grid line (paper Figs. 11-13, rolling only).

On an outcome grid (rows x columns of initial states, e.g. beta x omega1) a boundary crosses the
grid line between two 4-neighbouring cells of different outcome (a *link*). With a solver whose
outcome is exact (the reduced solver of the conservative rolling scene, ``simulate(...,
method="reduced")``: no step size, no missed event), :func:`bisect_links` bisects each link's
varying coordinate until the two ends are adjacent floating-point numbers, the outcome of one end
that of the first cell and of the other that of the second: the boundary to machine precision on
that grid line. What it is follows from the two ends (:data:`KINDS`):

- ``grazing``: the side that stays on the rim has f2_min -> 0 at the end (below ``f2_rel`` m g):
  the boundary is a root of the continuous f2_min, the minimum of F2 (31) grazing zero;
- ``separatrix``: a side that stays on the rim keeps f2_min away from 0: the outcome switches where
  the motion passes a saddle (a saddle connection, Sect. 5.1);
- ``falls``: both sides fall (in against out): a boundary of the free flight, not of rolling.

:func:`exact_curves` then draws the boundary curves of ``boundary_curves.trace`` (marching squares
on the cell centres, each crossing at a link's midpoint) through the located crossings instead,
and :func:`line_distances` measures how far another map's curves (e.g. an adaptive map's) cross the
same grid lines from them. ``run`` is any function of (row values, column values) returning
``simulate``'s columns ``outcome`` and ``f2_min``; pure numpy otherwise.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from rimroll.solver.analysis import boundary_curves
from rimroll.solver.engine import outcomes

KINDS = ("grazing", "separatrix", "falls")
"""Kinds of a located crossing (index = code in :class:`Crossings` ``kind``)."""
F2_REL = 1e-6
"""f2_min [N] below F2_REL m g at a rim side's end of a located crossing: a grazing of F2."""
MAX_HALVINGS = 1100
"""Bound on the bisection: a link's interval halves to adjacent doubles in at most ~1075 steps."""
FALLS = (outcomes.FALL_IN, outcomes.FALL_OUT)


@dataclass(frozen=True)
class Crossings:
    """Located crossings, one per link: ``i``, ``j`` the first cell, ``axis`` 0 (the link runs along
    the rows: the row value varies) or 1 (columns); ``lo``, ``hi``: the varying coordinate at the two
    ends (adjacent doubles where ``converged``), outcome ``code_lo`` = the first cell's, ``code_hi``;
    ``f2_lo``, ``f2_hi`` [N]: f2_min at the ends; ``kind``: index into :data:`KINDS`."""

    i: np.ndarray
    j: np.ndarray
    axis: np.ndarray
    lo: np.ndarray
    hi: np.ndarray
    code_lo: np.ndarray
    code_hi: np.ndarray
    f2_lo: np.ndarray
    f2_hi: np.ndarray
    kind: np.ndarray
    converged: np.ndarray

    @property
    def at(self) -> np.ndarray:
        """The crossing's coordinate: the midpoint of the two ends."""
        return self.lo + 0.5 * (self.hi - self.lo)


def links(codes) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(i, j, axis) of every link between 4-neighbouring cells of different code: (i, j) and
    (i + 1, j) for axis 0, (i, j) and (i, j + 1) for axis 1."""
    codes = np.asarray(codes)
    i0, j0 = np.nonzero(codes[1:] != codes[:-1])
    i1, j1 = np.nonzero(codes[:, 1:] != codes[:, :-1])
    return (np.concatenate([i0, i1]), np.concatenate([j0, j1]),
            np.concatenate([np.zeros(i0.size, np.int8), np.ones(i1.size, np.int8)]))


def bisect_links(run: Callable, rows, cols, codes, weight: float, f2_rel: float = F2_REL) -> Crossings:
    """Every link of ``codes`` (rows x columns outcome codes of the states (rows[i], cols[j])) bisected
    to adjacent doubles with ``run(row_values, col_values) -> {"outcome", "f2_min"}``, all links at once
    (one ``run`` call per halving). ``weight``: m g [N], the scale of ``f2_rel``. A midpoint whose outcome
    is neither end's (a third outcome inside the link) is taken as the second end's side: the crossing
    found is then the first cell's boundary."""
    rows, cols, codes = np.asarray(rows, float), np.asarray(cols, float), np.asarray(codes)
    i, j, axis = links(codes)
    along = axis == 0
    i2, j2 = i + along, j + ~along
    fixed = np.where(along, cols[j], rows[i])
    lo, hi = np.where(along, rows[i], cols[j]), np.where(along, rows[i2], cols[j2])
    code_lo, code_hi = codes[i, j], codes[i2, j2]
    ends = run(np.where(along, lo, fixed), np.where(along, fixed, lo))
    f2_lo = np.asarray(ends["f2_min"], float).copy()
    ends = run(np.where(along, hi, fixed), np.where(along, fixed, hi))
    f2_hi = np.asarray(ends["f2_min"], float).copy()
    for _ in range(MAX_HALVINGS):
        mid = lo + 0.5 * (hi - lo)
        active = (mid != lo) & (mid != hi)
        if not active.any():
            break
        k = np.flatnonzero(active)
        res = run(np.where(along[k], mid[k], fixed[k]), np.where(along[k], fixed[k], mid[k]))
        first = np.asarray(res["outcome"]) == code_lo[k]
        f2 = np.asarray(res["f2_min"], float)
        lo[k[first]], f2_lo[k[first]] = mid[k[first]], f2[first]
        hi[k[~first]], f2_hi[k[~first]] = mid[k[~first]], f2[~first]
    mid = lo + 0.5 * (hi - lo)
    converged = (mid == lo) | (mid == hi)
    return Crossings(i, j, axis, lo, hi, code_lo, code_hi, f2_lo, f2_hi,
                     _kinds(code_lo, code_hi, f2_lo, f2_hi, f2_rel * weight), converged)


def _kinds(code_lo, code_hi, f2_lo, f2_hi, f2_tol: float) -> np.ndarray:
    """:data:`KINDS` codes: both sides fall; else grazing if a side that stays on the rim ends with
    f2_min < f2_tol [N]; else separatrix."""
    rim_lo, rim_hi = ~np.isin(code_lo, FALLS), ~np.isin(code_hi, FALLS)
    grazing = (rim_lo & (f2_lo < f2_tol)) | (rim_hi & (f2_hi < f2_tol))
    return np.where(~rim_lo & ~rim_hi, 2, np.where(grazing, 0, 1)).astype(np.int8)


def exact_curves(crossings: Crossings, rows, cols, codes) -> tuple[boundary_curves.Curves, np.ndarray, np.ndarray]:
    """The boundary curves of ``codes`` (``boundary_curves.trace``) through the located crossings:
    returns (curves, row values, column values of their points): a point at a link's midpoint is moved
    to the link's crossing (:attr:`Crossings.at`); junction centres and the half-cell ends at the grid's
    edge stay where the trace puts them (``boundary_curves.on_axes``)."""
    curves = boundary_curves.trace(np.asarray(codes))
    r, c = boundary_curves.on_axes(curves.points, rows, cols)
    key = np.rint(2 * curves.points).astype(np.int64)  # link midpoints: one half-integer coordinate
    where = {}
    for n, (a, b, ax) in enumerate(zip(crossings.i, crossings.j, crossings.axis)):
        where[(2 * a + 1, 2 * b) if ax == 0 else (2 * a, 2 * b + 1)] = n
    at = crossings.at
    for p, (a, b) in enumerate(key):
        n = where.get((int(a), int(b)))
        if n is not None:
            if crossings.axis[n] == 0:
                r[p] = at[n]
            else:
                c[p] = at[n]
    return curves, r, c


def line_distances(crossings: Crossings, rows, cols, other_codes) -> np.ndarray:
    """For each located crossing, the distance along its grid line (in that line's units: the row
    coordinate for axis 0, the column's for axis 1) to the nearest crossing of the same line by the
    curves of another map ``other_codes`` on the same grid (e.g. an adaptive map's: its curves cross a
    line at the midpoints of its differing links); inf where that map has no boundary on the line."""
    rows, cols, other = np.asarray(rows, float), np.asarray(cols, float), np.asarray(other_codes)
    out = np.full(crossings.at.size, np.inf)
    mid_rows = 0.5 * (rows[1:] + rows[:-1])
    mid_cols = 0.5 * (cols[1:] + cols[:-1])
    for n, (a, b, ax) in enumerate(zip(crossings.i, crossings.j, crossings.axis)):
        if ax == 0:  # along the rows at column b
            there = mid_rows[np.flatnonzero(other[1:, b] != other[:-1, b])]
        else:
            there = mid_cols[np.flatnonzero(other[a, 1:] != other[a, :-1])]
        if there.size:
            out[n] = np.abs(there - crossings.at[n]).min()
    return out
