"""Regression against the stored reference slices (study/reference_slices, ``study reference --build``).

Each slice (the default grid's sub-grid and the whole ``--quick`` grid) is recomputed at its
study's default precision (outcome sections: dp5, rtol 1e-8, atol 1e-10; the references: DOP853
at rtol 1e-12) on the reference's grid and compared with
``study.compare``: categorical variables must be identical at every point away from boundaries
(all 4-neighbours of the point carry the same values in the reference), continuous variables
must agree within the tolerances below at those points.
"""

from __future__ import annotations

import numpy as np
import pytest
import xarray as xr

from rimroll.study import compare, reference, registry
from rimroll.study.io import open_result

# (atol, rtol) per continuous variable, |x - x_ref| <= atol + rtol |x_ref|, and why:
OUTCOME_TOLERANCES = {
    # dp5 at rtol 1e-8 against DOP853 at 1e-12, runs of up to 60 s: observed <= 2.2e-5 s; 10x margin
    "t_end": (2e-4, 2e-4),
    # the minimum of F2 is taken on the dense output (4th order for dp5): observed <= 5e-7 N at 99 %
    # of the points, up to 3.7e-5 N (4.7e-6 of F2 ~ 8 N) on periodic orbits of the rolling-only
    # scene, whose trough falls inside a long dp5 step (the cubic of the step, not the integration)
    "f2_min": (1e-4, 1e-5),
    # omega1 = 0 crossings located on the dense output to the event tolerance: observed <= 3e-9 s
    "half_period": (1e-7, 1e-7),
    # alpha quadrature over the whole run, same error budget as t_end: observed <= 1.4e-5
    "revolutions": (2e-4, 2e-4),
    # slip phases end on the switching tolerances (solver.physics.switching), observed <= 3e-7 s
    "slip_time": (1e-5, 1e-4),
    # conservative: integration drift ~1e-8..1e-7; dissipative: energy lost, O(1): observed <= 6e-7
    "energy_drift": (1e-5, 1e-4),
    # the state at t_end: observed <= 7.4e-8 rad and <= 1.3e-5 1/s (omega2 ~ 100 1/s)
    "beta_end": (1e-6, 1e-6),
    "omega1_end": (1e-4, 1e-5),
    "omega2_end": (1e-4, 1e-5),
    "omega3_end": (1e-4, 1e-5),
    # an integer count: identical away from boundaries
    "slip_phases": (0.0, 0.0),
}
# closed-form maps (fig3, fig5-fig8) and fig9's fixed-step Floquet integration: the same code
# path at any setting, so equal to round-off
MAP_TOLERANCES = {"omega20": (1e-12, 1e-12), "h": (1e-12, 1e-12), "required_friction": (1e-12, 1e-12),
                  "F2": (1e-12, 1e-12), "throw_speed": (1e-12, 1e-12), "trace_M": (1e-10, 1e-10),
                  "abs_mu1": (1e-10, 1e-10), "abs_mu2": (1e-10, 1e-10)}
MIN_AWAY = 0.7  # at least 70 % of a slice lies away from boundaries, or the comparison says little
EVERY_POINT = {"shot", "shot-probability", "rim-states"}  # maps of many small regions (a shot's outcomes), rebuilt
# by the same event-driven code: their categories must be identical at every point instead (a stronger check where
# few points lie away)


# (atol, rtol) of the studies whose reference is more precise than their default run, beyond what
# their variables declare: invariants at DOP853 rtol 1e-10 against 1e-12 (observed <= 3.2e-10 1/s in
# omega1 over 5 s at --quick); the cubes' outcomes as OUTCOME_TOLERANCES (dp5 at rtol 1e-6 against
# DOP853 at 1e-12: observed t_end <= 6.3e-7 s, revolutions <= 3.4e-7)
STUDY_TOLERANCES = {"outcome-cube": OUTCOME_TOLERANCES}
SLOW = {("work-precision", "default"), ("work-precision", "quick"),  # 30 s and 17 s of timed runs, on 2 cores
        ("shot-sensitivity", "default")}  # 12 cases x 4000 noisy shots, a drag case among them: minutes
SLICES = [pytest.param(name, grid, marks=pytest.mark.slow) if (name, grid) in SLOW else (name, grid)
          for name in reference.specs() for grid in reference.GRIDS]


def _tolerances(name, ref):
    if name in STUDY_TOLERANCES:
        return STUDY_TOLERANCES[name]
    return OUTCOME_TOLERANCES if "scene" in ref.dims else MAP_TOLERANCES


def test_every_study_has_a_small_slice_with_provenance():
    own = {ep.name for ep in registry.study_entry_points() if ep.value.startswith("rimroll.")}
    assert own <= set(reference.specs())  # study verify answers 0 or 1 for every study of rimroll
    total = 0
    for (name, grid), spec in (((n, g), reference.specs()[n]) for n in reference.specs() for g in reference.GRIDS):
        path = reference.reference_path(name, grid=grid)
        assert path.is_file(), f"missing {path}: run `study reference --build`"
        size = path.stat().st_size
        total += size
        assert size < 1_000_000
        with xr.open_dataset(path) as ds:
            assert ds.attrs["study"] == name
            for key in ("reference_command", "reference_settings", "reference_rtol", "reference_method",
                        "rimroll_version", "history", "created"):
                assert key in ds.attrs, (name, key)
            assert "study reference --build" in ds.attrs["reference_command"]
            assert ("--quick" in ds.attrs["reference_settings"]) == (grid == "quick")
            if spec.precise:
                assert ds.attrs["reference_rtol"] == "1e-12" and ds.attrs["setting_rtol"] == 1e-12
            # slices built before reference_precision was recorded (the maps', fig11-13's) lack it
            if "reference_precision" in ds.attrs:
                kind = "reference's own" if spec.precise else "regression reference"
                assert kind in ds.attrs["reference_precision"]
            if "boundary_type" in ds:  # the outcome sections, fig11-13
                assert ds.attrs["reference_method"] == "dop853" and ds.attrs["setting_method"] == "dop853"
                assert ds.sizes["beta"] == 24 and ds.sizes["omega1"] == 36 and ds.sizes["scene"] == 4
                assert "boundary_type" in ds
    # the slices ship inside the wheel: 22 studies, two grids each, stay under 6 MB (a budget, 250 kB a study
    # on average; the largest are the four-scene outcome sections, 240 kB each)
    assert total < 6_000_000, f"reference slices total {total / 1e6:.2f} MB, over the 6 MB budget"


def test_the_quick_slice_is_the_whole_quick_grid():
    """What ``study run NAME --quick`` computes, every point of it (so verify covers all of it)."""
    from rimroll.study import registry
    from rimroll.study.plan import make_plan

    for name in reference.specs():
        with xr.open_dataset(reference.reference_path(name, grid="quick")) as ref:
            for axis in make_plan(registry.get(name), quick=True).axes:
                np.testing.assert_array_equal(ref[axis.name].values, axis.values, err_msg=f"{name} {axis.name}")


@pytest.mark.parametrize("name,grid", SLICES)
def test_default_settings_reproduce_the_reference(name, grid):
    """Each slice recomputed at its study's default precision (the same plan as ``study run NAME
    --quick`` for the quick slice) agrees with the stored one: what ``study verify`` says of a
    fresh run."""
    ds = reference.recompute(name, workers=2, grid=grid)
    ref = open_result(reference.reference_path(name, grid=grid))
    tolerances = _tolerances(name, ref)
    report = compare.compare(ds, ref, tolerances)
    text = "\n".join(compare.format_report(report, f"recomputed {name}", "reference"))
    assert report.n_common == np.prod(list(ref.sizes.values())), text
    assert report.ok, text
    cats = [v for v in report.variables if v.kind == "categorical"]
    assert cats or name in ("fig3", "invariants", "work-precision", "shot-sensitivity")
    for v in cats:
        if name in EVERY_POINT:
            assert v.identical == 1.0, text
        else:
            assert v.n_away >= MIN_AWAY * v.n_compared, text
    compared = {v.name for v in report.variables if v.kind == "continuous"}
    assert compared >= (set(tolerances) & set(ref.data_vars)), text
    if name == "fig11":  # the physics the slices pin down: periodic rolling exists in the conservative scenes
        assert (ref["outcome"].values[:2] == 2).any()


def test_a_perturbed_slice_fails():
    """The comparison is not vacuous: one outcome flipped away from boundaries, or t_end off by
    10x its tolerance, fails."""
    ref = open_result(reference.reference_path("fig11"))
    bad = ref.copy(deep=True)
    bad["outcome"].values[0, 0, 0] = 3 - bad["outcome"].values[0, 0, 0]  # a corner, far from any boundary
    assert not compare.compare(bad, ref, OUTCOME_TOLERANCES).ok
    bad = ref.copy(deep=True)
    bad["t_end"].values[0, 0, 0] += 10 * (2e-4 + 2e-4 * float(ref["t_end"].values[0, 0, 0]))
    report = compare.compare(bad, ref, OUTCOME_TOLERANCES)
    assert not report.ok and [v.name for v in report.variables if not v.ok] == ["t_end"]
