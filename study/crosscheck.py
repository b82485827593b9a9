"""Cross-check: the exact reduced solver against the engine on the stored reference slices.

``study crosscheck [NAME ...]`` (docs/how-to/verify.md) reruns, with
``solver.simulate(..., method="reduced")`` (paper Sect. 4.4: the conservative rolling motion as a
quadrature on the level set of (60), (62), (68)), every cell of a study's stored reference slice
whose scene the reduced solver can solve (mu = inf, no rolling or drilling resistance, no air), and
compares it with the slice, which the engine computed (fig11-13: DOP853 at rtol 1e-12).

A slice can be checked if it holds ``outcome`` (and ``t_end``, else outcomes only) per initial
state, its states are a grid of (beta, omega1) at recorded omega2, omega3 (or along their axes), and
its dimensions are those and ``scene``. Per conservative rolling-only scene (the reduced solver
refuses the others in one line, which the report names) it reports:

- cells compared, outcome differences, and how many of these are *near a boundary* (:func:`near_boundary`:
  decided on the slice's own grid, among the 4-neighbours of the cell in the same scene, where the two
  maps agree, one has the slice's outcome and one the reduced solver's). A difference away from every
  boundary fails the check;
- the t_end difference [s], median and max over the cells where both outcomes agree and the slice's
  t_end > 0 (a state that falls at t = 0 has nothing to compare). It fails if the median exceeds
  :data:`MEDIAN_FACTOR` x rtol [s] or the max :data:`MAX_FACTOR` x rtol x max(1, t_max) [s], rtol
  being the slice's recorded one (the engine's tolerance).

Reads files and prints nothing: :func:`check_study` returns a :class:`Check`, :func:`summary` its line.
"""

from __future__ import annotations

import dataclasses

import numpy as np
import xarray as xr

from rimroll import solver
from rimroll.solver.engine import scenes
from rimroll.study import io, reference
from rimroll.study.dataset import params_of, setting_of

MEDIAN_FACTOR = 10.0
"""The median t_end difference may be at most this x the slice's rtol [s] (1e-11 s at rtol 1e-12)."""
MAX_FACTOR = 1e3
"""The largest t_end difference may be at most this x rtol x max(1, t_max) [s] (2e-8 s at rtol 1e-12,
t_max 20 s: a passage close to a saddle loses accuracy in both solvers)."""
STATE = ("beta", "omega1", "omega2", "omega3")
DIMS = (*STATE, "scene")


@dataclasses.dataclass
class SceneCheck:
    """One scene of a slice compared: counts [cells] and t_end differences [s]."""

    scene: str
    cells: int
    differ: int
    near_boundary: int
    dt_median: float
    dt_max: float
    dt_allowed: tuple  # (median, max) [s]

    @property
    def ok(self) -> bool:
        within = not np.isfinite(self.dt_median) or (self.dt_median <= self.dt_allowed[0]
                                                     and self.dt_max <= self.dt_allowed[1])
        return self.differ == self.near_boundary and within


@dataclasses.dataclass
class Check:
    """A study's slice cross-checked: the scenes compared, and those (or the whole study) not, with why."""

    study: str
    grid: str
    scenes: list = dataclasses.field(default_factory=list)
    skipped: dict = dataclasses.field(default_factory=dict)  # scene -> why not
    why_not: str = ""  # the whole slice cannot be checked

    @property
    def checked(self) -> bool:
        return bool(self.scenes)

    @property
    def ok(self) -> bool:
        return all(s.ok for s in self.scenes)


def _unsupported(ds: xr.Dataset) -> str:
    """Why the slice's cells are not simulate() states the reduced solver could rerun ('' if they are)."""
    if "outcome" not in ds.data_vars:
        return f"its slice holds no outcome per initial state (variables: {', '.join(ds.data_vars)})"
    other = [d for d in ds["outcome"].dims if d not in DIMS]
    if other:
        return f"its cells are not (beta, omega1, omega2, omega3) states: dimension(s) {', '.join(other)}"
    for name in STATE:
        if name not in ds["outcome"].dims:
            try:
                float(setting_of(ds, name))
            except (KeyError, ValueError):
                return f"its slice records no {name} of the initial states"
    return ""


def _scene_params(ds: xr.Dataset, k: int | None) -> tuple[solver.Params, float]:
    """Parameters and t_max [s] of scene ``k`` of the slice (None: the file has no scene axis)."""
    p = params_of(ds)
    if k is None:
        return p, float(setting_of(ds, "t_max"))
    label = str(ds["scene"].values[k])
    named = {s.name: s for s in scenes.NAMED}
    if label in named:  # a named scene switches every other term off
        p = p.replace(**named[label].parameters(1.0, 0.0))
    p = p.replace(**{c: float(ds[c].values[k]) for c in ("mu", "k_r", "k_d") if c in ds.coords})
    return p, float(ds["t_max"].values[k])


def _states(ds: xr.Dataset) -> tuple[np.ndarray, tuple]:
    """Initial states (..., 4) on the grid of the slice's outcome without its scene axis, and that shape."""
    grid = ds["outcome"].isel(scene=0) if "scene" in ds["outcome"].dims else ds["outcome"]
    columns = []
    for name in STATE:
        if name in grid.dims:
            columns.append(xr.broadcast(grid[name], grid)[0].transpose(*grid.dims).values)
        else:
            columns.append(np.full(grid.shape, float(setting_of(ds, name))))
    return np.stack(columns, axis=-1).astype(float), grid.shape


def _neighbours(a: np.ndarray, axis: int, step: int) -> np.ndarray:
    """``a`` shifted by ``step`` along ``axis``: each cell's neighbour there (-1 beyond the grid's edge)."""
    out = np.full(a.shape, -1, dtype=np.int64)
    src, dst = [slice(None)] * a.ndim, [slice(None)] * a.ndim
    src[axis], dst[axis] = (slice(step, None), slice(None, -step)) if step > 0 else (slice(None, step),
                                                                                       slice(-step, None))
    out[tuple(dst)] = a[tuple(src)]
    return out


def near_boundary(ref: np.ndarray, mine: np.ndarray) -> np.ndarray:
    """Cells whose outcome differs between the two maps and that lie on a boundary of those two
    outcomes: among their 4-neighbours on the grid (every axis), where both maps agree, one has the
    slice's outcome of the cell and one the reduced solver's. A lone wrong cell amid neighbours of one
    outcome is not near a boundary."""
    ref, mine = np.asarray(ref, dtype=np.int64), np.asarray(mine, dtype=np.int64)
    has_ref, has_mine = np.zeros(ref.shape, bool), np.zeros(ref.shape, bool)
    for axis in range(ref.ndim):
        for step in (1, -1):
            r, m = _neighbours(ref, axis, step), _neighbours(mine, axis, step)
            agreed = (r == m) & (r >= 0)
            has_ref |= agreed & (r == ref)
            has_mine |= agreed & (r == mine)
    return (ref != mine) & has_ref & has_mine


def compare_scene(ds: xr.Dataset, k: int | None, label: str) -> SceneCheck | str:
    """Rerun scene ``k`` of slice ``ds`` with the reduced solver and compare; a str: why it cannot."""
    params, t_max = _scene_params(ds, k)
    states, shape = _states(ds)
    sel = ds.isel(scene=k) if k is not None else ds
    rtol = float(setting_of(ds, "rtol"))
    try:
        res = solver.simulate(states, params, t_max=t_max, rtol=rtol, method="reduced", workers=1)
    except ValueError as e:
        return str(e)
    grid_dims = [d for d in ds["outcome"].dims if d != "scene"]
    ref_out = sel["outcome"].transpose(*grid_dims).values
    # outcomes only where the slice has no t_end: no cell then has a t_end to compare
    ref_t = sel["t_end"].transpose(*grid_dims).values if "t_end" in sel else np.zeros(shape)
    out, t_end = np.asarray(res["outcome"]).reshape(shape), np.asarray(res["t_end"]).reshape(shape)
    differ = out != ref_out
    same = ~differ & (ref_t > 0)
    dt = np.abs(t_end - ref_t)[same]
    allowed = (MEDIAN_FACTOR * rtol, MAX_FACTOR * rtol * max(1.0, t_max))
    return SceneCheck(label, int(out.size), int(differ.sum()), int(near_boundary(ref_out, out).sum()),
                      float(np.median(dt)) if dt.size else np.nan, float(dt.max()) if dt.size else np.nan, allowed)


def check_dataset(ds: xr.Dataset, study: str, grid: str = "default") -> Check:
    """Cross-check every scene of the slice ``ds`` of ``study`` that the reduced solver can solve."""
    check = Check(study, grid, why_not=_unsupported(ds))
    if check.why_not:
        return check
    if "scene" in ds["outcome"].dims:
        labels = [(k, str(v)) for k, v in enumerate(ds["scene"].values)]
    else:
        labels = [(None, "all cells")]
    for k, label in labels:
        result = compare_scene(ds, k, label)
        if isinstance(result, str):
            check.skipped[label] = result
        else:
            check.scenes.append(result)
    return check


def check_study(name: str, directory=None, grid: str = "default") -> Check:
    """Cross-check the stored ``grid`` slice of study ``name`` (in ``directory``, default the packaged
    slices; none there: not checked, and why); a :class:`registry.UserError` if the study has no slices."""
    reference.spec_of(name)
    path = reference.reference_path(name, directory, grid)
    if not path.is_file():
        return Check(name, grid, why_not=f"no {grid} reference slice at {path}")
    with io.open_result(path) as ds:
        return check_dataset(ds.load(), name, grid)


def _g(x: float) -> str:
    return f"{x:.2g}" if np.isfinite(x) else "n/a"


def summary(check: Check) -> str:
    """One line: per scene compared, cells, outcome differences (near a boundary), t_end median / max
    difference [s] against what is allowed; the scenes or the study not checked, with why."""
    head = f"{check.study} ({check.grid} slice): "
    if check.why_not:
        return head + "not checked: " + check.why_not
    parts = [f"{s.scene}: {s.cells} cells, {s.differ} outcome differences ({s.near_boundary} near a boundary), "
             + (f"t_end difference median {_g(s.dt_median)} s, max {_g(s.dt_max)} s (allowed {_g(s.dt_allowed[0])}, "
                f"{_g(s.dt_allowed[1])})" if np.isfinite(s.dt_max) else "no t_end compared")
             + f": {'ok' if s.ok else 'FAILED'}" for s in check.scenes]
    if check.skipped:  # the reduced solver's one-line refusal: what it runs; got what the scene has
        heads = sorted({why.split("; got ")[0] for why in check.skipped.values()})
        scenes_got = [f"{label} ({why.split('; got ')[1]})" if "; got " in why else label
                      for label, why in check.skipped.items()]
        parts.append("not checked: " + ", ".join(scenes_got) + ": " + "; ".join(heads))
    if not check.scenes:
        return head + "not checked: " + "; ".join(parts)
    return head + "; ".join(parts)


def main(names, directory=None, grid: str = "default") -> int:
    """``study crosscheck``: one line per study (:func:`summary`); exit 1 if a check failed or none
    could be checked, else 0. An unknown name is a :class:`registry.UserError` (exit 2)."""
    names = list(names) or list(reference.specs())
    for name in names:
        reference.spec_of(name)  # an unknown name fails before anything runs
    checks = []
    for name in names:
        checks.append(check_study(name, directory, grid))
        print(summary(checks[-1]), flush=True)
    failed = [c.study for c in checks if not c.ok]
    done = [c.study for c in checks if c.checked]
    if failed:
        print(f"cross-check FAILED: {', '.join(failed)}")
    elif not done:
        print("cross-check: nothing checked (no slice holds a scene the reduced solver solves)")
    else:
        print(f"cross-check ok: {', '.join(done)}")
    return 1 if failed or not done else 0
