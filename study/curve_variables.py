"""The boundary curves of an outcome section in a results file: polylines with their boundary type.

``solver.analysis.boundary_curves`` traces, per scene, the polylines between the cells of
different ``outcome`` (through the midpoints of the cell edges between them), each labelled with
the two outcomes it separates and the type of the boundary of periodic rolling it runs along
(``boundary_type`` of its cells; ``not_boundary`` for a boundary between other outcomes). They
are stored in the layout of a CF contiguous ragged array (CF 9.3.3), the curves one after the
other along ``boundary_point``:

- ``boundary_omega1(boundary_point)`` [1/s], ``boundary_beta(boundary_point)`` [rad]: the points;
- ``boundary_node_count(boundary_curve)``: how many points each curve has (curve k holds the
  points from the sum of the counts before it on);
- along ``boundary_curve``: ``boundary_curve_type`` (flags of ``boundary_type``),
  ``boundary_curve_scene`` (flags: the scene labels) and ``boundary_curve_outcome_a`` <
  ``boundary_curve_outcome_b`` (flags of ``outcome``).

Neither CF's ``sample_dimension`` attribute (reserved to discrete sampling geometries, which
need a ``featureType`` the file is not) nor a CF-1.8 line geometry (its node coordinates need an
``axis``, which both CF checkers refuse on a coordinate in 1/s) fits a map of outcomes, so the
count variable says the layout in words. Every variable opens with plain ``xarray``.

A map without any boundary (one outcome everywhere, in every scene) gets no curve variables
(netCDF has no fixed dimension of length 0). Used by the outcome-section studies (fig11-13).
"""

from __future__ import annotations

import numpy as np

from rimroll.solver.analysis import boundaries, boundary_curves
from rimroll.solver.engine import outcomes

COUNT = "boundary_node_count"
NAMES = (COUNT, "boundary_omega1", "boundary_beta", "boundary_curve_type", "boundary_curve_scene",
         "boundary_curve_outcome_a", "boundary_curve_outcome_b")
"""The variables of the curves in a file."""
CURVE, POINT = "boundary_curve", "boundary_point"


def trace_scene(outcome, cell_type, beta, omega1) -> dict:
    """The boundary curves of one (beta, omega1) section: ``{"omega1", "beta": point coordinates
    [1/s, rad], "sizes": points per curve, "type", "outcome_a", "outcome_b": per curve}``, from
    its outcome codes and boundary types (``boundary_curves.trace`` and ``link_types``)."""
    outcome = np.asarray(outcome)
    types = boundary_curves.link_types(outcome, cell_type) if cell_type is not None else None
    c = boundary_curves.trace(outcome, types)
    b, w = boundary_curves.on_axes(c.points, beta, omega1)
    return {"omega1": w, "beta": b, "sizes": c.sizes, "type": c.link_type, "outcome_a": c.code_a,
            "outcome_b": c.code_b}


def variables(outcome, cell_type, beta, omega1, scenes) -> dict:
    """The derived variables of the curves of every scene (``Study.derive``'s
    ``{name: (dims, values, attrs)}``; empty when no scene has a boundary). ``outcome``,
    ``cell_type``: (scene, beta, omega1) codes; ``beta`` [rad], ``omega1`` [1/s]: the grid;
    ``scenes``: the scene labels."""
    parts = [trace_scene(outcome[k], cell_type[k], beta, omega1) for k in range(len(scenes))]
    sizes = np.concatenate([p["sizes"] for p in parts])
    if sizes.size == 0:
        return {}
    def cat(key):
        return np.concatenate([p[key] for p in parts])
    scene = np.concatenate([np.full(p["sizes"].size, k, dtype=np.int8) for k, p in enumerate(parts)])
    outcome_flags = {"flag_values": np.array(outcomes.OUTCOME_FLAG_VALUES, dtype="int8"),
                     "flag_meanings": outcomes.OUTCOME_FLAG_MEANINGS}
    n_points = int(sizes.sum())
    return {
        # index coordinates of the two ragged dimensions: files of several sections combine with
        # xr.concat / open_mfdataset (the shorter lists are padded, see of_scene)
        CURVE: ((CURVE,), np.arange(sizes.size, dtype=np.int32), {
            "units": "1", "long_name": "index of the boundary curve", "ragged_index": 1}),
        POINT: ((POINT,), np.arange(n_points, dtype=np.int32), {
            "units": "1", "long_name": "index of the point of the boundary curves", "ragged_index": 1}),
        COUNT: ((CURVE,), sizes.astype(np.int32), {
            "units": "1", "long_name": "number of points of each boundary curve between outcome regions",
            "comment": "a contiguous ragged array: the points of curve k are boundary_omega1 and boundary_beta "
                       "from the sum of the counts of curves 0 to k-1 on; each curve is a polyline through the "
                       "midpoints of the cell edges between cells of different outcome, joined where two pieces "
                       "of one kind meet; a closed curve ends at its first point (solver.analysis.boundary_curves; "
                       "docs/outcome-studies.md#boundary-curves)"}),
        "boundary_omega1": ((POINT,), cat("omega1"), {
            "units": "s-1", "long_name": "omega1 of the points of the boundary curves"}),
        "boundary_beta": ((POINT,), cat("beta"), {
            "units": "rad", "long_name": "beta of the points of the boundary curves"}),
        "boundary_curve_type": ((CURVE,), cat("type").astype(np.int8), {
            "units": "1", "long_name": "type of the boundary of periodic rolling the curve runs along",
            "flag_values": np.array(boundaries.BOUNDARY_FLAG_VALUES, dtype="int8"),
            "flag_meanings": boundaries.BOUNDARY_FLAG_MEANINGS,
            "comment": "a link between a periodic cell and a falling or still-on-the-rim one takes the "
                       "boundary_type both cells have, or where they differ the one later in the order "
                       "separatrix_and_deadlock, deadlock, slipping_induced, separatrix, undetermined; "
                       "not_boundary: a boundary between other outcomes"}),
        "boundary_curve_scene": ((CURVE,), scene, {
            "units": "1", "long_name": "scene of the curve",
            "flag_values": np.arange(len(scenes), dtype="int8"), "flag_meanings": " ".join(map(str, scenes))}),
        "boundary_curve_outcome_a": ((CURVE,), cat("outcome_a").astype(np.int8), {
            **outcome_flags, "units": "1",
            "long_name": "outcome on one side of the curve (the smaller code)"}),
        "boundary_curve_outcome_b": ((CURVE,), cat("outcome_b").astype(np.int8), {
            **outcome_flags, "units": "1",
            "long_name": "outcome on the other side of the curve (the larger code)"}),
    }


def of_scene(ds, label: str) -> list[tuple[np.ndarray, int]] | None:
    """The curves of scene ``label`` stored in ``ds``: ``[(points (k, 2) as (omega1, beta), type)]``;
    None when the file stores no curves (a file written before them)."""
    if COUNT not in ds.variables:
        return None
    scene = ds["boundary_curve_scene"]
    codes = dict(zip(scene.attrs["flag_meanings"].split(), np.asarray(scene.attrs["flag_values"]).tolist()))
    if str(label) not in codes:
        return []
    counts = np.asarray(ds[COUNT].values, dtype=float)
    kept = np.isfinite(counts)  # files combined along an axis pad the shorter lists with NaN at the end
    counts = counts[kept].astype(int)
    ends = np.cumsum(counts)
    w, b = ds["boundary_omega1"].values, ds["boundary_beta"].values
    kinds = np.asarray(ds["boundary_curve_type"].values)[kept]
    scene_of = np.asarray(scene.values)[kept]
    return [(np.stack([w[e - n:e], b[e - n:e]], 1), int(kinds[k]))
            for k, (n, e) in enumerate(zip(counts, ends)) if scene_of[k] == codes[str(label)]]


def traced(outcome, cell_type, beta, omega1) -> list[tuple[np.ndarray, int]]:
    """The curves of one section traced now (a file without stored curves), as :func:`of_scene`."""
    t = trace_scene(outcome, cell_type, beta, omega1)
    ends = np.cumsum(t["sizes"])
    return [(np.stack([t["omega1"][e - n:e], t["beta"][e - n:e]], 1), int(t["type"][k]))
            for k, (n, e) in enumerate(zip(t["sizes"], ends))]
