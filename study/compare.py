"""Compare a result with a stored reference slice on their common coordinates.

Common points: for every dimension of the reference, the file's coordinate values that match a
reference value to within ``COORD_RTOL`` of the axis' span (nearest match; +inf, a swept mu,
matches only +inf); auxiliary coordinates along a dimension (a scene's mu, k_r, k_d, t_max) must
match too. A setting one of the two sweeps and the other holds at one value (a cube's slice on a
few settings) is compared at that value. Settings that change the physics (``param_*`` and the
non-numerical ``setting_*`` such as omega2, t_max) must be equal, else there are no common
points. Categorical variables (``flag_values``) are compared
for identity, at all common points and at those *away from boundaries* (all 4-neighbours of the
point in the reference carry the same value, in every computed categorical variable of the
reference; along a dimension of :data:`DISCRETE_DIMS`, such as a sample of unrelated states, there
is no boundary). Derived variables (``boundary_type``, which marks boundaries itself; ``S_b``) and a
study's whole-grid ones (``Var.pointwise`` False: a box's entropy) are compared only when the
file's grid is the reference's: they depend on the neighbours on their own grid;
continuous variables as a scaled error ``|x - x_ref| / (atol + rtol |x_ref|)`` at the points
away from boundaries where every categorical variable agrees (elsewhere they describe different
motions), with NaN == NaN and inf == inf of the same sign counted as equal.

A result passes only if it holds every variable of the reference (but those its study never
compares: ``Var.compared`` False, such as ``n_steps`` and timings, or a derived variable with the
attribute ``rimroll_compared = 0``; the report names them), and if its common points cover at
least :data:`MIN_COVERAGE` of the reference's points: a coarse grid that shares a few corners
with the slice has checked almost nothing. Polylines (a ragged array along dimensions without
coordinates, such as the boundary curves of an outcome map) are not compared: they are drawn from the categorical
variables, which are.
"""

from __future__ import annotations

import dataclasses
import math

import numpy as np
import xarray as xr

COORD_RTOL = 1e-6
# settings that only set grid size or precision: they may differ between a file and the reference
NUMERICAL_SETTINGS = ("rtol", "atol", "method", "max_steps", "backend", "adaptive", "adaptive_coarse", "slip_method")
"""How, not what, is computed (an adaptive map is the same map: its filled cells are not compared as
continuous values, ``SIMULATED``; ``slip_method``: the steps of a slip phase, Rodas4 or explicit, solve the
same equations)."""
SIMULATED = "refine_level"
"""A file's per-cell variable saying which cells were simulated (>= 0) and which were filled from a
uniform block's corners (-1, solver/analysis/adaptive_map.py): continuous variables are compared at the first only."""
DEFAULT_TOLERANCE = (1e-9, 1e-9)
"""(atol, rtol) of a continuous variable whose study declares no tolerance of its own (``Var.tolerance``;
the outputs of ``simulate`` declare theirs in ``solver.engine.outputs``)."""
MIN_AGREEMENT_AWAY = 1.0  # categorical: fraction identical away from boundaries needed to pass
MIN_COVERAGE = 0.5  # common points / points of the reference slice needed to pass
DISCRETE_DIMS = ("scene", "integrator", "sample", "trajectory")
"""Dimensions whose neighbours are unrelated (labels, seeded samples): no boundary lies between them."""


@dataclasses.dataclass
class VarReport:
    name: str
    kind: str  # "categorical" or "continuous"
    n_compared: int
    identical: float = math.nan  # categorical: fraction identical at all common points
    identical_away: float = math.nan  # categorical: fraction identical away from boundaries
    n_away: int = 0
    worst: float = math.nan  # continuous: worst |x - x_ref|
    worst_scaled: float = math.nan  # continuous: worst error / (atol + rtol |x_ref|)
    tolerance: tuple = ()
    ok: bool = True


@dataclasses.dataclass
class Report:
    study: str
    n_common: int
    reason: str = ""  # why there are no common points
    variables: list = dataclasses.field(default_factory=list)
    n_reference: int = 0  # points of the reference slice
    missing: list = dataclasses.field(default_factory=list)  # reference variables absent from the file
    skipped: list = dataclasses.field(default_factory=list)  # never compared: integrator work, timings
    mismatches: int = 0  # settings that differ from the reference's (then nothing is compared)

    @property
    def coverage(self) -> float:
        return self.n_common / self.n_reference if self.n_reference else 0.0

    @property
    def ok(self) -> bool:
        return (self.n_common > 0 and bool(self.variables) and not self.missing
                and self.coverage >= MIN_COVERAGE and all(v.ok for v in self.variables))


def _defaults(study: str) -> dict:
    """The default settings and physical parameters of ``study`` (empty for an unknown study)."""
    from rimroll.study import registry
    from rimroll.study.settings import default_settings

    try:
        return default_settings(registry.get(study))
    except registry.UserError:
        return {}


def _same(mine, theirs) -> bool:
    """Whether a file's setting and a reference's are the same value: numbers to 1e-12 (inf only inf),
    anything else as text."""
    try:
        a, b = float(mine), float(theirs)
    except (TypeError, ValueError):
        return str(mine) == str(theirs)
    return a == b or bool(np.isclose(a, b, rtol=1e-12, atol=0.0))


def _setting_mismatch(ds: xr.Dataset, ref: xr.Dataset) -> list[str]:
    out = []
    # a setting or parameter the reference does not record is one added after it was made: it was
    # computed at the default (a refined eps test is not the sampled one the reference holds; a
    # Coulomb c_r > 0 is not the c_r = 0 of a reference made before c_r existed)
    defaults = _defaults(str(ref.attrs.get("study")))
    for key in ds.attrs:
        name = key.split("_", 1)[1] if key.startswith(("setting_", "param_")) else None
        if name is None or key in ref.attrs or name in NUMERICAL_SETTINGS or name.startswith("n_"):
            continue
        default = defaults.get(name)
        if isinstance(default, (str, bool, int, float)) and not _same(ds.attrs[key], default):
            out.append(f"{name}: {ds.attrs[key]} (file) vs {default} (reference: made before the setting existed, "
                       "at its default)")
    for key, value in ref.attrs.items():
        if not (key.startswith("param_") or key.startswith("setting_")):
            continue
        name = key.split("_", 1)[1]
        if name in NUMERICAL_SETTINGS or name.startswith("n_") or name in ds.dims:
            continue  # how it was computed, a grid size, or an axis the file sweeps (aligned later)
        if key in ds.attrs:
            mine = ds.attrs[key]
        elif name in ds.coords and ds[name].ndim == 0:  # a scalar coordinate
            mine = ds[name].values[()]
        else:  # a file edited, or written before the setting existed: not known to be equal
            out.append(f"{name}: not recorded in the file vs {value} (reference)")
            continue
        if not _same(mine, value):
            out.append(f"{name}: {mine} (file) vs {value} (reference)")
    return list(dict.fromkeys(out))  # a name recorded both as param_ and setting_ (mu of fig8) is said once


def _match(file_values: np.ndarray, ref_values: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Indices (file, reference) of values matching within COORD_RTOL of the axis' span; string
    labels (a ``scene``) match when equal."""
    if file_values.dtype.kind in "UOS" or ref_values.dtype.kind in "UOS":
        file_labels = [str(v) for v in file_values]
        pairs = [(file_labels.index(str(v)), k) for k, v in enumerate(ref_values) if str(v) in file_labels]
        return np.array([i for i, _ in pairs], dtype=int), np.array([k for _, k in pairs], dtype=int)
    file_values, ref_values = file_values.astype(float), ref_values.astype(float)
    finite = ref_values[np.isfinite(ref_values)]
    span = max(float(np.ptp(finite)), float(np.max(np.abs(finite))), 1e-300) if finite.size else 1.0
    tol = COORD_RTOL * span
    idx_f, idx_r = [], []
    for k, v in enumerate(ref_values):
        with np.errstate(invalid="ignore"):  # inf - inf: a mu = inf matches only mu = inf
            d = np.where(file_values == v, 0.0, np.abs(file_values - v))
        d = np.where(np.isnan(d), np.inf, d)
        i = int(np.argmin(d)) if d.size else -1
        if i >= 0 and d[i] <= tol:
            idx_f.append(i)
            idx_r.append(k)
    return np.array(idx_f, dtype=int), np.array(idx_r, dtype=int)


def _span(coord) -> str:
    """'lo..hi' of a numeric coordinate, or its labels."""
    values = coord.values
    if values.dtype.kind in "UOS":
        return ", ".join(str(v) for v in values)
    return f"{float(values.min()):.4g}..{float(values.max()):.4g}"


def _away_from_boundaries(ref: xr.Dataset, names: list[str]) -> np.ndarray:
    """Points of the reference whose 4-neighbours (along every dimension) share their value in
    every categorical variable ``names``; edge points count their existing neighbours only."""
    dims = list(ref[names[0]].dims) if names else list(ref.sizes)
    shape = tuple(ref.sizes[d] for d in dims)
    away = np.ones(shape, dtype=bool)
    for name in names:
        v = ref[name].transpose(*dims).values
        for ax in range(v.ndim):
            if dims[ax] in DISCRETE_DIMS or v.shape[ax] < 2:
                continue  # scenes, samples, trajectories are not a continuum: no boundary between neighbours
            same = v[(slice(None),) * ax + (slice(1, None),)] == v[(slice(None),) * ax + (slice(None, -1),)]
            lo = [slice(None)] * v.ndim
            hi = [slice(None)] * v.ndim
            lo[ax], hi[ax] = slice(1, None), slice(None, -1)
            away[tuple(lo)] &= same
            away[tuple(hi)] &= same
    return away


def declared(study: str) -> tuple[dict, set, set]:
    """The tolerances the variables of ``study`` declare (``Var.tolerance``: name -> (atol, rtol)), the
    names of those never compared (``Var.compared``: integrator work, timings) and of those that
    depend on the whole grid (``Var.pointwise``: compared on the reference's own grid only); empty
    for an unknown study."""
    from rimroll.study import registry

    try:
        variables = registry.get(study).variables
    except registry.UserError:
        return {}, set(), set()
    return ({v.name: v.tolerance for v in variables if v.tolerance is not None},
            {v.name for v in variables if not v.compared}, {v.name for v in variables if not v.pointwise})


def _scalar(ds: xr.Dataset, name: str) -> float | str | None:
    """The one value of setting ``name`` in a file that does not sweep it: a 0-d coordinate, or its
    ``setting_``/``param_`` attribute, a number or a label (``geometry``); None if the file says nothing."""
    if name in ds.coords and ds[name].ndim == 0:
        value = ds[name].values[()]
    else:
        value = ds.attrs.get(f"setting_{name}", ds.attrs.get(f"param_{name}"))
    try:
        return float(value)
    except (TypeError, ValueError):
        return str(value) if isinstance(value, str) and value else None


def _align(ds: xr.Dataset, ref: xr.Dataset) -> tuple[xr.Dataset, xr.Dataset, str]:
    """``ds`` and ``ref`` on the same dimensions, and "" (else the reason why they cannot be): an
    axis that one of them sweeps and the other holds at one value (a setting attribute or a 0-d
    coordinate) is cut at that value (a cube's reference slice on a few settings; a file that holds
    k_r = 0 against a slice that sweeps k_r); a dimension of length 1 is dropped."""
    ds = ds.squeeze([d for d in ds.dims if d not in ref.dims and ds.sizes[d] == 1], drop=True)
    ds, why = _cut(ds, ref, "file", "reference")
    if why:
        return ds, ref, why
    ref, why = _cut(ref, ds, "reference", "file")
    return ds, ref, why


def _cut(swept: xr.Dataset, held: xr.Dataset, name: str, other: str) -> tuple[xr.Dataset, str]:
    """``swept`` at the value ``held`` holds of each axis only ``swept`` has, and "" (else why not)."""
    for d in [d for d in swept.dims if d not in held.dims]:
        value = _scalar(held, d)
        if isinstance(value, str):  # a label axis (geometry): matched by label
            index = np.flatnonzero(swept[d].values.astype(str) == value)
        else:
            index, _ = _match(swept[d].values, np.array([value])) if value is not None else (np.empty(0), None)
        if not index.size:
            shown = value if isinstance(value, str) else f"{value:g}" if value is not None else ""
            says = f"holds {d} = {shown}" if value is not None else f"has no {d}"
            return swept, f"dimensions differ: the {name} sweeps {d}, the {other} {says}"
        swept = swept.isel({d: int(index[0])}, drop=True)
    return swept, ""


def _grid_only(ds: xr.Dataset) -> xr.Dataset:
    """``ds`` without its ragged arrays (the boundary curves of an outcome map): the variables along
    a dimension that has no coordinate or whose index coordinate says ``ragged_index`` (points or
    curves, not an axis of the grid). They are drawn
    from the grid's categorical variables, which are compared."""
    return ds.drop_dims([d for d in ds.dims if d not in ds.coords or ds[d].attrs.get("ragged_index")])


def compare(ds: xr.Dataset, ref: xr.Dataset, tolerances: dict | None = None) -> Report:
    """Agreement of ``ds`` with the reference slice ``ref`` (see the module docstring); ``tolerances``
    (name -> (atol, rtol)) override those the study declares."""
    study = str(ref.attrs.get("study"))
    tol, not_compared, whole_grid = declared(study)
    tol.update(tolerances or {})
    mismatch = _setting_mismatch(ds, ref)
    if mismatch:
        return Report(study, 0, "settings differ, so no point is common: " + "; ".join(mismatch),
                      mismatches=len(mismatch))
    ds, ref = _grid_only(ds), _grid_only(ref)
    n_reference = int(np.prod(list(ref.sizes.values())))
    ds, ref, why = _align(ds, ref)
    if why:
        return Report(study, 0, why, n_reference=n_reference)
    dims = [d for d in ref.dims]
    sel_f, sel_r = {}, {}
    for d in dims:
        i_f, i_r = _match(ds[d].values, ref[d].values)
        for name, c in ref.coords.items():  # auxiliary coordinates along d must match as well
            if name != d and c.dims == (d,) and name in ds.coords and i_f.size:
                a, b = ds[name].values[i_f].astype(float), c.values[i_r].astype(float)
                keep = (a == b) | np.isclose(a, b, rtol=1e-12, atol=0.0)
                i_f, i_r = i_f[keep], i_r[keep]
        if i_f.size == 0:
            return Report(study, 0, f"no common values of {d!r} (file {_span(ds[d])}, reference {_span(ref[d])})")
        sel_f[d], sel_r[d] = i_f, i_r
    a = ds.isel(sel_f)
    b = ref.isel(sel_r)
    not_compared |= {n for n in ref.data_vars if str(ref[n].attrs.get("rimroll_compared", 1)) == "0"}
    names = [n for n in ref.data_vars if n in ds.data_vars and n not in not_compared]
    if not all(len(sel_f[d]) == ds.sizes[d] == ref.sizes[d] for d in dims):
        # a derived variable (boundary_type, S_b) and a study's whole-grid one (a box's entropy) describe
        # the neighbours on their own grid: another grid has other neighbours, so only the same grid compares them
        names = [n for n in names if not (ref[n].attrs.get("rimroll_derived") or n in whole_grid)]
    categorical = [n for n in names if "flag_values" in ref[n].attrs]
    continuous = [n for n in names if n not in categorical]
    away_full = _away_from_boundaries(ref, [n for n in ref.data_vars if "flag_values" in ref[n].attrs
                                            and not ref[n].attrs.get("rimroll_derived")])
    cat_dims = list(ref[categorical[0]].dims) if categorical else dims
    away = away_full[np.ix_(*[sel_r[d] for d in cat_dims])] if categorical else np.ones(
        tuple(len(sel_r[d]) for d in cat_dims), dtype=bool)
    report = Report(study, int(np.prod([len(sel_r[d]) for d in dims])), n_reference=n_reference,
                    missing=[n for n in ref.data_vars if n not in ds.data_vars and n not in not_compared],
                    skipped=sorted(n for n in not_compared if n in ref.data_vars))
    agree_all = np.ones_like(away)
    for n in categorical:
        x, y = a[n].transpose(*cat_dims).values, b[n].transpose(*cat_dims).values
        same = x == y
        agree_all &= same
        frac_away = float(same[away].mean()) if away.any() else math.nan
        report.variables.append(VarReport(
            n, "categorical", same.size, identical=float(same.mean()), identical_away=frac_away,
            n_away=int(away.sum()), ok=not away.any() or frac_away >= MIN_AGREEMENT_AWAY))
    mask = away & agree_all
    if SIMULATED in a.data_vars and tuple(a[SIMULATED].dims) == tuple(cat_dims):  # filled cells hold interpolations
        mask = mask & (a[SIMULATED].transpose(*cat_dims).values >= 0)
    for n in continuous:
        order = [d for d in cat_dims if d in a[n].dims]  # an outer variable (an area) lacks the grid's axes
        x = a[n].transpose(*order, ...).values.astype(float)
        y = b[n].transpose(*order, ...).values.astype(float)
        atol, rtol = tol.get(n, DEFAULT_TOLERANCE)
        with np.errstate(invalid="ignore", divide="ignore"):
            equal = (x == y) | (np.isnan(x) & np.isnan(y))
            err = np.where(equal, 0.0, np.abs(x - y))
            err = np.where(np.isnan(err), np.inf, err)  # one NaN, or inf against a number
            scaled = np.where(err == 0.0, 0.0, err / (atol + rtol * np.where(np.isfinite(y), np.abs(y), 0.0)))
        m = mask if mask.shape == x.shape else np.ones_like(x, dtype=bool)
        worst = float(err[m].max()) if m.any() else 0.0
        worst_scaled = float(scaled[m].max()) if m.any() else 0.0
        report.variables.append(VarReport(n, "continuous", int(m.sum()), worst=worst, worst_scaled=worst_scaled,
                                          tolerance=(atol, rtol), ok=worst_scaled <= 1.0))
    return report


def format_report(report: Report, file: str, ref_path: str) -> list[str]:
    """Human-readable lines of a :class:`Report`."""
    if report.n_common == 0:
        return [f"{file}: study {report.study}: nothing to compare with {ref_path}: {report.reason}"]
    lines = [f"{file} vs reference {ref_path} (study {report.study}): {report.n_common} common points"]
    for v in report.variables:
        mark = "ok  " if v.ok else "FAIL"
        if v.kind == "categorical":
            lines.append(f"  {mark} {v.name:<14} categorical: {100 * v.identical:.2f}% identical; "
                         f"{100 * v.identical_away:.2f}% of {v.n_away} points away from boundaries "
                         f"(needed {100 * MIN_AGREEMENT_AWAY:.0f}%)")
        else:
            lines.append(f"  {mark} {v.name:<14} continuous: worst |error| {v.worst:.3g} over {v.n_compared} points "
                         f"= {v.worst_scaled:.3g} x tolerance (atol {v.tolerance[0]:g}, rtol {v.tolerance[1]:g})")
    compared = ", ".join(v.name for v in report.variables) or "nothing"
    lines.append(f"compared: {compared}")
    if report.skipped:
        lines.append(f"not compared (not reproducible from run to run: integrator work, timings): "
                     f"{', '.join(report.skipped)}")
    if report.missing:
        lines.append(f"  FAIL missing from the file: {', '.join(report.missing)}")
    mark = "ok  " if report.coverage >= MIN_COVERAGE else "FAIL"
    lines.append(f"  {mark} coverage: {report.n_common} of the reference's {report.n_reference} points compared "
                 f"({100 * report.coverage:.1f}%, needed {100 * MIN_COVERAGE:.0f}%)")
    values_ok = all(v.ok for v in report.variables) and not report.missing
    if report.ok:
        verdict = "within tolerance"
    elif values_ok:  # every value compared agrees: too little of the reference was compared to say more
        verdict = (f"NOT verified: every value compared is within tolerance, but the file covers only "
                   f"{100 * report.coverage:.1f}% of the reference's points (needed {100 * MIN_COVERAGE:.0f}%)")
    else:
        verdict = "NOT within tolerance"
    lines.append(f"result: {verdict}")
    return lines
