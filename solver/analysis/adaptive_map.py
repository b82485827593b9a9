"""Adaptive outcome maps: a (beta, omega1) section whose cost grows with its boundaries, not its area.

A full map simulates every cell of the target grid. :func:`adaptive_map` simulates a coarse
lattice of it (every ``coarse``-th row and column, the last row and column included), then
refines, level by level (stride ``coarse``, ``coarse / 2``, ..., 1), only the blocks of the
lattice that are not uniform, and fills each uniform block from its corners:

- a block is **uniform** when every simulated state on its perimeter (its corners, and the edge
  points a refined neighbour simulated) has the same *class* (``outcome``, ``on_rim_reason``
  and whether it slipped at all, ``slip_phases > 0``) and the cheap indicators stay small across
  it (:data:`INDICATORS`: revolutions, half period, F2_min); any other block is refined (its
  midpoints simulated) and its four children are judged at the next level;
- a block kept uniform is looked at again after each refinement of its neighbours: a point they
  simulated on its edge that differs sends it to refinement too, so a boundary that crosses a
  block edge is followed into the next block;
- the boundary typing of ``solver.analysis.boundaries.classify`` reads the inner neighbour of
  each periodic cell of a boundary pair: a last pass simulates those that were filled;
- the **coarse level** guards against small islands: an island whose extent is at least the
  coarse stride in beta and omega1 holds a lattice point; narrower ones are found by the
  indicators (F2_min, half period and revolutions change fast on approach to a boundary).

What is filled: categorical and integer fields from the nearest corner, floating-point fields by
bilinear interpolation of the four corners (all four of one class). ``level`` says, per cell,
at which stride it was simulated (0: the target grid, k: stride 2**k) or -1 (filled).

Pure: the simulation is a callback ``run(i, j) -> {field: values}`` on flat cell indices (a study
passes in ``solver.simulate`` with its own scene and options); the study settings that switch it on
(``adaptive``, ``adaptive_coarse``) are the study layer's, ``rimroll.study.outcome_sections``.
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np

DEFAULT_COARSE = 8
"""Cells between the lattice points of the coarse level (a power of 2); see the module docstring."""
INDICATORS = {
    "revolutions": 0.5,  # a change of more than half a revolution around the rim across a block
    "half_period_rel": 0.25,  # a relative change of the half period (periodic blocks) above 25 %
    "f2_rel": 0.2,  # a change of F2_min above 0.2 m g
}
"""The cheap indicators of refinement (what is compared: max - min over a block's simulated perimeter)."""
FILLED = -1
"""``level`` of a cell filled from its block's corners (not simulated)."""


def lattice(n: int, stride: int) -> np.ndarray:
    """Indices 0, stride, 2 stride, ... of an axis of ``n`` cells, and its last index n - 1."""
    return np.union1d(np.arange(0, n, stride), [n - 1])


def check_coarse(coarse: int) -> int:
    """``coarse`` as an int; ValueError unless a power of 2 (1 means: no adaptivity)."""
    c = int(coarse)
    if c < 1 or c & (c - 1):
        raise ValueError(f"adaptive_coarse must be a power of 2 (1, 2, 4, 8, ...); got {coarse!r}")
    return c


def _rectangle(a: int, c: int, perimeter: bool) -> tuple[np.ndarray, np.ndarray]:
    """Offsets (rows, columns) of the cells of an a x c block [0, a] x [0, c]: its perimeter or all."""
    r, q = np.meshgrid(np.arange(a + 1), np.arange(c + 1), indexing="ij")
    keep = ((r == 0) | (r == a) | (q == 0) | (q == c)) if perimeter else np.ones(r.shape, dtype=bool)
    return r[keep], q[keep]


def _by_shape(blocks: np.ndarray):
    """Groups of ``blocks`` (B, 4: i0, i1, j0, j1) of one shape: (selection, a, c) with a = i1 - i0, c = j1 - j0."""
    shape = blocks[:, [1, 3]] - blocks[:, [0, 2]]
    for a, c in np.unique(shape, axis=0):
        yield np.nonzero((shape[:, 0] == a) & (shape[:, 1] == c))[0], int(a), int(c)


class _Grid:
    """The target grid being filled: the fields, the level of each simulated cell, the callback."""

    def __init__(self, run: Callable, shape: tuple, weight: float):
        self.run, self.shape, self.weight = run, shape, weight
        self.level = np.full(shape, FILLED, dtype=np.int8)
        self.klass = np.zeros(shape, dtype=np.int64)
        self.fields: dict[str, np.ndarray] = {}

    def simulate(self, i: np.ndarray, j: np.ndarray, level: int) -> np.ndarray:
        """Simulate the cells (i, j) not simulated yet; they get ``level``. Returns their flat indices."""
        i, j = np.asarray(i, dtype=np.intp).ravel(), np.asarray(j, dtype=np.intp).ravel()
        flat = np.unique(np.ravel_multi_index((i, j), self.shape))
        flat = flat[self.level.flat[flat] == FILLED]
        if not flat.size:
            return flat
        ii, jj = np.unravel_index(flat, self.shape)
        out = self.run(ii, jj)
        for name, values in out.items():
            values = np.asarray(values)
            if name not in self.fields:
                fill = np.nan if values.dtype.kind == "f" else 0
                self.fields[name] = np.full(self.shape, fill, dtype=values.dtype)
            self.fields[name][ii, jj] = values
        self.level[ii, jj] = level
        # the class: outcome, on_rim_reason, slipped at all
        f = self.fields
        code = f["outcome"][ii, jj].astype(np.int64) * 1000
        if "on_rim_reason" in f:
            code += f["on_rim_reason"][ii, jj].astype(np.int64) * 10
        if "slip_phases" in f:
            code += f["slip_phases"][ii, jj] > 0
        self.klass[ii, jj] = code
        return flat

    def touching(self, blocks: np.ndarray, flat: np.ndarray) -> np.ndarray:
        """Per block (B, 4): whether one of the cells ``flat`` (sorted flat indices) lies in it, edges
        included: per row of each block, the cells between its first and last column, counted by
        binary search in ``flat`` (no pass over the whole grid)."""
        if not flat.size or not len(blocks):
            return np.zeros(len(blocks), dtype=bool)
        i0, i1, j0, j1 = blocks.T
        rows_per = i1 - i0 + 1
        block = np.repeat(np.arange(len(blocks)), rows_per)
        first = np.repeat(np.cumsum(rows_per) - rows_per, rows_per)
        row = i0[block] + (np.arange(block.size) - first)
        lo, hi = row * self.shape[1] + j0[block], row * self.shape[1] + j1[block]
        inside = np.searchsorted(flat, hi, side="right") - np.searchsorted(flat, lo, side="left")
        return np.bincount(block, weights=inside, minlength=len(blocks)) > 0

    def uniform(self, blocks: np.ndarray) -> np.ndarray:
        """Per block (B, 4): whether the simulated cells on its perimeter agree in class and indicators."""
        ok = np.ones(len(blocks), dtype=bool)
        for sel, a, c in _by_shape(blocks):
            tr, tc = _rectangle(a, c, perimeter=True)
            ii, jj = blocks[sel, 0][:, None] + tr, blocks[sel, 2][:, None] + tc
            sim = self.level[ii, jj] != FILLED
            k = self.klass[ii, jj]
            same = np.where(sim, k, np.iinfo(np.int64).max).min(1) == np.where(sim, k, np.iinfo(np.int64).min).max(1)
            ok[sel] = same & ~self._indicated(ii, jj, sim)
        return ok

    def _indicated(self, ii, jj, sim) -> np.ndarray:
        """Per row: whether a cheap indicator changes by more than its threshold across the cells ``sim``."""
        hit = np.zeros(ii.shape[0], dtype=bool)
        for name, key in (("revolutions", "revolutions"), ("half_period", "half_period_rel"), ("f2_min", "f2_rel")):
            if name not in self.fields:
                continue
            v = self.fields[name][ii, jj]
            valid = sim & np.isfinite(v)
            lo, hi = np.where(valid, v, np.inf).min(1), np.where(valid, v, -np.inf).max(1)
            scale = {"revolutions": 1.0, "half_period": np.abs(lo), "f2_min": self.weight}[name]
            with np.errstate(invalid="ignore"):
                hit |= valid.any(1) & (hi - lo > INDICATORS[key] * scale)
        return hit

    def fill(self, blocks: np.ndarray, names=None) -> None:
        """Fill the cells of uniform blocks not simulated: nearest corner, bilinear for floats; only the
        fields ``names`` (None: all)."""
        fields = [arr for name, arr in self.fields.items() if names is None or name in names]
        for sel, a, c in _by_shape(blocks):
            tr, tc = _rectangle(a, c, perimeter=False)
            i0, j0 = blocks[sel, 0][:, None], blocks[sel, 2][:, None]
            ii, jj = i0 + tr, j0 + tc
            todo = self.level[ii, jj] == FILLED
            if not todo.any():
                continue
            u, v = tr / max(a, 1), tc / max(c, 1)
            ni, nj = i0 + np.where(u <= 0.5, 0, a), j0 + np.where(v <= 0.5, 0, c)  # nearest corner
            for arr in fields:
                if arr.dtype.kind == "f":
                    c00, c01, c10, c11 = (arr[i0 + p, j0 + q] for p, q in ((0, 0), (0, c), (a, 0), (a, c)))
                    values = (1 - u) * (1 - v) * c00 + (1 - u) * v * c01 + u * (1 - v) * c10 + u * v * c11
                else:
                    values = arr[ni, nj]
                arr[ii[todo], jj[todo]] = values[todo]


def _children(block, rows: np.ndarray, cols: np.ndarray) -> list:
    """The blocks of the finer lattice (``rows``, ``cols``) inside ``block``."""
    i0, i1, j0, j1 = block
    r = rows[(rows >= i0) & (rows <= i1)]
    c = cols[(cols >= j0) & (cols <= j1)]
    return [(int(a), int(b), int(p), int(q)) for a, b in zip(r[:-1], r[1:]) for p, q in zip(c[:-1], c[1:])]


def _points(blocks, rows: np.ndarray, cols: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The points of the finer lattice inside ``blocks`` (corners included)."""
    ii, jj = [], []
    for i0, i1, j0, j1 in blocks:
        r = rows[(rows >= i0) & (rows <= i1)]
        c = cols[(cols >= j0) & (cols <= j1)]
        a, b = np.meshgrid(r, c, indexing="ij")
        ii.append(a.ravel())
        jj.append(b.ravel())
    if not ii:
        return np.zeros(0, np.intp), np.zeros(0, np.intp)
    return np.concatenate(ii), np.concatenate(jj)


def _level(grid: _Grid, blocks: np.ndarray, kept: list, stride: int) -> np.ndarray:
    """One level: refine the blocks that are not uniform (simulate their points of the lattice of
    stride ``stride // 2``) and add the others to ``kept`` (arrays of blocks); a kept block (of any
    level) that then sees a differing point on its edge is refined too, until none does. Returns
    the children of the refined blocks, the blocks of the next level."""
    half = stride // 2
    rows, cols = lattice(grid.shape[0], half), lattice(grid.shape[1], half)
    level = int(np.log2(half))
    ok = grid.uniform(blocks)
    refine, todo = [blocks[~ok]], blocks[~ok]
    kept.append(blocks[ok])
    while len(todo):
        new = grid.simulate(*_points(todo, rows, cols), level)
        old = np.concatenate(kept)
        ok = np.ones(len(old), dtype=bool)
        again = grid.touching(old, new)  # a kept block's verdict changes only with a new cell on its edge
        ok[again] = grid.uniform(old[again])
        kept[:] = [old[ok]]
        todo = old[~ok]
        refine.append(todo)
    refine = np.concatenate(refine)
    return np.array([c for b in refine for c in _children(b, rows, cols)], dtype=np.intp).reshape(-1, 4)


def _inner_neighbours(grid: _Grid, periodic_code: int, falls: tuple) -> int:
    """Simulate the filled inner neighbours P_in of the periodic cells P of each boundary pair
    (P, F) (what ``boundaries.classify`` reads); repeated while that finds new pairs. Returns
    how many it simulated."""
    total = 0
    for _ in range(8):
        out = grid.fields["outcome"]
        periodic, other = out == periodic_code, np.isin(out, falls)
        need = np.zeros(grid.shape, dtype=bool)
        for axis in (0, 1):
            for step in (1, -1):
                pair = periodic & np.roll(other, -step, axis=axis)  # P, with F = P + step
                _clear_wrapped(pair, axis, step)
                inner = np.roll(pair, -step, axis=axis)  # P_in = P - step: inner[k] = pair[k + step]
                _clear_wrapped(inner, axis, step)
                need |= inner
        need &= grid.level == FILLED
        if not need.any():
            return total
        i, j = np.nonzero(need)
        grid.simulate(i, j, 0)
        total += i.size
    return total


def _clear_wrapped(mask: np.ndarray, axis: int, step: int) -> None:
    """Zero the row/column of ``mask`` that ``np.roll(..., -step, axis)`` wrapped around."""
    idx = [slice(None)] * 2
    idx[axis] = -1 if step > 0 else 0
    mask[tuple(idx)] = False


def adaptive_map(run: Callable, shape: tuple, coarse: int = DEFAULT_COARSE, *, weight: float,
                 periodic_code: int, falls: tuple, inner_neighbours: bool = True,
                 filled=None) -> tuple[dict, np.ndarray]:
    """The fields of every cell of a (beta, omega1) grid of ``shape``, simulating few of them.

    ``run(i, j) -> {field: 1-D values}``: simulate the cells (i, j) (integer arrays); ``coarse``:
    the stride of the coarse lattice (a power of 2; 1 simulates every cell); ``weight``: m g [N],
    the scale of the F2_min indicator; ``periodic_code``, ``falls``: the outcome codes of
    periodic rolling and of its other side (fall in, fall out, still on the rim);
    ``inner_neighbours``: also simulate the cells the boundary typing reads (False: a map for
    other uses, e.g. the eps pairs of the predictability study); ``filled``: the fields filled in the
    uniform blocks (None: all; the others keep NaN / 0 at the cells not simulated). Returns
    (``{field: array of shape}``, ``level``: int8, the stride exponent each cell was simulated
    at, :data:`FILLED` where filled).
    """
    coarse = check_coarse(coarse)
    grid = _Grid(run, tuple(shape), weight)
    rows, cols = lattice(shape[0], coarse), lattice(shape[1], coarse)
    a, b = np.meshgrid(rows, cols, indexing="ij")
    grid.simulate(a, b, int(np.log2(coarse)))
    blocks = np.array(_children((0, shape[0] - 1, 0, shape[1] - 1), rows, cols), dtype=np.intp).reshape(-1, 4)
    kept: list = [np.zeros((0, 4), dtype=np.intp)]
    stride = coarse
    while stride > 1:
        blocks = _level(grid, blocks, kept, stride)
        stride //= 2
    grid.fill(np.concatenate(kept), filled)
    if inner_neighbours:
        _inner_neighbours(grid, periodic_code, falls)
    return grid.fields, grid.level


NEEDED = ("outcome", "on_rim_reason", "slip_phases", "revolutions", "half_period", "f2_min")
"""The fields the refinement reads (the class and the indicators), kept whatever a study stores."""


def section(run: Callable, beta: np.ndarray, omega1: np.ndarray, coarse: int, weight: float, keep=None) -> dict:
    """Every field of one (beta, omega1) grid, plus ``refine_level``, from an adaptive map.

    ``run(beta, omega1) -> {field: values}``: the simulation of these states (1-D arrays), passed in
    (``solver.simulate`` with the study's scene, tolerances and options); ``beta``, ``omega1``: the
    grid's coordinates broadcast to its shape (leading axes of length 1); ``coarse``: the stride of
    the coarse lattice (a power of 2); ``weight``: m g [N]; ``keep``: the fields wanted (None: all;
    the others are not filled, which saves memory and time on large grids).
    """
    from rimroll.solver.engine import outcomes

    shape = beta.shape
    b2, w2 = beta.reshape(shape[-2:]), omega1.reshape(shape[-2:])
    if beta.size != b2.size:
        raise ValueError(f"an adaptive map needs one whole (beta, omega1) grid per chunk; got shape {shape}")
    falls = (outcomes.FALL_IN, outcomes.FALL_OUT, outcomes.ON_RIM_AT_T_MAX)
    names = None if keep is None else set(keep) | set(NEEDED)

    def cells(i, j):
        out = run(b2[i, j], w2[i, j])
        return out if names is None else {k: v for k, v in out.items() if k in names}
    fields, level = adaptive_map(cells, b2.shape, int(coarse), weight=weight,
                                 periodic_code=outcomes.PERIODIC_ROLLING, falls=falls, filled=keep)
    out = {name: values.reshape(shape) for name, values in fields.items() if keep is None or name in keep}
    out["refine_level"] = level.reshape(shape)
    return out


def n_simulated(level: np.ndarray, axes=(-2, -1)) -> np.ndarray:
    """Cells simulated (``refine_level`` >= 0) over the grid ``axes``."""
    return (np.asarray(level) != FILLED).sum(axis=axes)
