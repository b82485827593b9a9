"""Adaptive outcome maps (``solver.analysis.adaptive_map``, ``--set adaptive=true``): the refinement on synthetic
maps, and on the paper's sections the adaptive map equals the full one cell for cell (outcome and
boundary type): on the --quick grids by default, on the 12 panels at 360 x 240 in a slow test."""

from __future__ import annotations

import numpy as np
import pytest
import xarray as xr

from rimroll.solver.analysis import adaptive_map as adaptive
from rimroll.study import outcome_sections

PERIODIC, IN, OUT = 2, 0, 1


def _synthetic(nb=240, nw=360, island=0.05, centre=(0.3, 0.2)):
    """A wavy boundary between fall in and fall out, and a round periodic island of radius ``island``
    (in units of the beta range), with F2_min falling to 0 at the island's rim (a deadlock boundary)."""
    b, w = np.meshgrid(np.linspace(0, 1, nb), np.linspace(-1, 1, nw), indexing="ij")

    def run(i, j):
        bb, ww = b[i, j], w[i, j]
        r = np.hypot(bb - centre[0], ww - centre[1])
        out = np.where(bb + 0.3 * np.sin(5 * ww) > 0.5, IN, OUT)
        out = np.where(r < island, PERIODIC, out)
        return {"outcome": out.astype(np.int8), "f2_min": np.minimum(np.abs(r - island) * 5, 1.0),
                "revolutions": 0.1 * ww, "half_period": np.where(out == PERIODIC, 1.0, np.nan),
                "slip_phases": np.zeros(bb.shape, np.int32)}
    return run, (nb, nw), b


def _both(run, shape, coarse):
    calls = []

    def counted(i, j):
        calls.append(i.size)
        return run(i, j)
    fields, level = adaptive.adaptive_map(counted, shape, coarse, weight=1.0, periodic_code=PERIODIC,
                                          falls=(IN, OUT))
    full = run(*np.meshgrid(np.arange(shape[0]), np.arange(shape[1]), indexing="ij"))
    return fields, level, full, sum(calls)


def test_lattice_and_coarse_rule():
    assert adaptive.lattice(10, 4).tolist() == [0, 4, 8, 9]
    assert adaptive.lattice(9, 4).tolist() == [0, 4, 8]
    assert adaptive.check_coarse(8) == 8
    for bad in (0, 3, 6, -2):
        with pytest.raises(ValueError, match="power of 2"):
            adaptive.check_coarse(bad)


def test_synthetic_map_is_identical_with_a_fraction_of_the_runs():
    run, shape, _ = _synthetic()
    fields, level, full, n = _both(run, shape, 8)
    assert (fields["outcome"] == full["outcome"]).all()
    assert n == (level != adaptive.FILLED).sum() < 0.1 * level.size  # each cell simulated at most once
    assert set(np.unique(level)) == {adaptive.FILLED, 0, 1, 2, 3}
    # filled floats: bilinear between simulated corners, exact for the linear revolutions
    np.testing.assert_allclose(fields["revolutions"], full["revolutions"], atol=1e-12)


def test_coarse_one_simulates_every_cell():
    run, _, _ = _synthetic(24, 36)
    fields, level, full, n = _both(run, (24, 36), 1)
    assert n == 24 * 36 and (level == 0).all() and (fields["outcome"] == full["outcome"]).all()


def test_an_island_between_lattice_points_is_found_by_the_f2_indicator_only():
    # radius 0.01 of the beta range: 2.4 cells, no lattice point of stride 16 inside, far from the other boundary
    run, shape, _ = _synthetic(island=0.01, centre=(0.8, -0.6))
    fields, _, full, _ = _both(run, shape, 16)
    assert (full["outcome"] == PERIODIC).sum() > 0
    assert (fields["outcome"] == full["outcome"]).all()
    saved = dict(adaptive.INDICATORS)
    try:
        adaptive.INDICATORS["f2_rel"] = np.inf  # without the indicator the island is lost
        fields, _, _, _ = _both(run, shape, 16)
        assert not (fields["outcome"] == PERIODIC).any()
    finally:
        adaptive.INDICATORS.update(saved)


def test_inner_neighbours_of_boundary_pairs_are_simulated():
    # boundaries.classify reads P, its falling neighbour F = P + d and its inner neighbour P - d
    run, shape, _ = _synthetic(island=0.1)
    fields, level, _, _ = _both(run, shape, 8)
    periodic = fields["outcome"] == PERIODIC
    checked = 0
    for i, j in np.argwhere(periodic):
        for di, dj in ((1, 0), (-1, 0), (0, 1), (0, -1)):
            f, inner = (i + di, j + dj), (i - di, j - dj)
            if all(0 <= x < n for x, n in zip(f + inner, shape + shape)) and not periodic[f]:
                assert level[i, j] != adaptive.FILLED and level[f] != adaptive.FILLED
                assert level[inner] != adaptive.FILLED, (i, j, di, dj)
                checked += 1
    assert checked > 50


def test_full_map_is_one_call_with_level_zero():
    beta, omega1 = np.meshgrid(np.linspace(0.8, 1.8, 4), np.linspace(-1, 1, 5), indexing="ij")
    calls = []

    def run(b, w):
        calls.append(b.shape)
        return {"outcome": np.zeros(b.shape, np.int8)}
    out = outcome_sections.map_section(run, beta, omega1, {"adaptive": False, "adaptive_coarse": 8}, 1.0)
    assert calls == [(4, 5)] and (out["refine_level"] == 0).all()
    adaptive_chunks = outcome_sections.adaptive_chunks
    assert adaptive_chunks({"adaptive": True, "n_beta": 240, "n_omega1": 360}, {"scene": 1, "beta": 24}) == {
        "scene": 1, "beta": 240, "omega1": 360}
    assert adaptive_chunks({"adaptive": False}, {"scene": 1, "beta": 24}) == {"scene": 1, "beta": 24}


@pytest.mark.parametrize("name", ["fig11", "outcome-cube", "continuation"])
def test_a_coarse_stride_not_a_power_of_two_is_a_user_error(name):
    from rimroll.study import registry
    from rimroll.study.plan import make_plan
    from rimroll.study.registry import UserError

    with pytest.raises(UserError, match="power of 2"):
        make_plan(registry.get(name), True, {"adaptive": True, "adaptive_coarse": 6})


def test_adaptive_and_full_runs_never_share_a_fingerprint():
    from rimroll.study import registry
    from rimroll.study.plan import make_plan

    study = registry.get("fig12")
    full = make_plan(study, quick=True)
    adapt = make_plan(study, True, {"adaptive": True})
    assert full.fingerprint != adapt.fingerprint
    assert adapt.block == (1, 24, 36) and full.block == (1, 24, 36)
    big = make_plan(study, False, {"adaptive": True})
    assert big.block == (1, 240, 360) and make_plan(study).block == (1, 24, 360)


def test_code_digest_covers_the_adaptive_module():
    """A change of the adaptive-map algorithm (solver/analysis/adaptive_map.py) or of the outcome sections'
    settings (study/outcome_sections.py) changes the fingerprint of fig11-13, so no part of an older adaptive
    map is reused: the first is a source of the solver's digest, the second a module the study imported."""
    import pathlib

    from rimroll.solver import _jit
    from rimroll.study import plan, registry

    solver_root = pathlib.Path(_jit.__file__).resolve().parent  # every .py under it: _jit.sources_digest
    assert pathlib.Path(adaptive.__file__).resolve().is_relative_to(solver_root)
    for name in ("fig12", "outcome-cube", "continuation"):
        assert "outcome_sections.py" in {p.name for p in plan._sibling_sources(registry.get(name).compute)}, name


def _compare(full: xr.Dataset, adapt: xr.Dataset) -> dict:
    """{scene: (outcome differences, boundary_type differences, n_simulated, cells)}."""
    out = {}
    for scene in full["scene"].values:
        a, b = full.sel(scene=scene), adapt.sel(scene=scene)
        out[str(scene)] = (int((a["outcome"] != b["outcome"]).sum()),
                           int((a["boundary_type"] != b["boundary_type"]).sum()),
                           int(b["n_simulated"]), int(a["outcome"].size))
    return out


def _run(name, out, *sets):
    from rimroll.study.cli import main

    extra = [x for s in sets for x in ("--set", s)]
    assert main(["run", name, "--out", str(out), "--no-progress", *extra]) == 0
    return xr.open_dataset(out / f"{name}.nc")


@pytest.mark.parametrize("name", ["fig11", "fig12", "fig13"])
def test_quick_adaptive_sections_equal_the_full_ones(name, tmp_path):
    full = _run(name, tmp_path / "full", "n_beta=24", "n_omega1=36")
    adapt = _run(name, tmp_path / "adaptive", "n_beta=24", "n_omega1=36", "adaptive=true", "adaptive_coarse=4")
    assert adapt.attrs["setting_adaptive"] == 1 and adapt.attrs["setting_adaptive_coarse"] == 4
    assert (full["refine_level"] == 0).all() and (full["n_simulated"] == 24 * 36).all()
    for scene, (d_out, d_bnd, n_sim, cells) in _compare(full, adapt).items():
        assert d_out == 0 and d_bnd == 0, (name, scene, d_out, d_bnd)
        assert n_sim < cells and n_sim == int((adapt["refine_level"].sel(scene=scene) >= 0).sum())
    # a simulated cell holds exactly the full map's numbers
    sim = adapt["refine_level"] >= 0
    for var in ("t_end", "f2_min", "revolutions", "slip_phases"):
        np.testing.assert_array_equal(adapt[var].where(sim), full[var].where(sim))


@pytest.mark.slow
@pytest.mark.parametrize("name", ["fig11", "fig12", "fig13"])
def test_paper_panels_adaptive_equal_full_at_360_by_240(name, tmp_path):
    """The 12 panels: identical cell for cell (outcome and boundary type), with <= 25 % of the runs."""
    full = _run(name, tmp_path / "full")
    adapt = _run(name, tmp_path / "adaptive", "adaptive=true")
    result = _compare(full, adapt)
    for scene, (d_out, d_bnd, _, _) in result.items():
        assert d_out == 0 and d_bnd == 0, (name, scene, d_out, d_bnd)
    assert sum(r[2] for r in result.values()) <= 0.25 * sum(r[3] for r in result.values()), result


def test_quick_outcome_cube_adaptive_equals_full(tmp_path):
    full = _run("outcome-cube", tmp_path / "full", "n_beta=12", "n_omega1=18", "mu=1,2", "k_r=0,0.02", "k_d=0",
                "omega2=65,105")
    adapt = _run("outcome-cube", tmp_path / "adaptive", "n_beta=12", "n_omega1=18", "mu=1,2", "k_r=0,0.02", "k_d=0",
                 "omega2=65,105", "adaptive=true", "adaptive_coarse=4")
    assert (adapt["outcome"] == full["outcome"]).all()
    assert adapt["n_simulated"].dims == ("mu", "k_r", "omega2")
    assert (adapt["n_simulated"] < 12 * 18).all() and (full["n_simulated"] == 12 * 18).all()
    assert (adapt["n_simulated"] == (adapt["refine_level"] >= 0).sum(("beta", "omega1"))).all()


def test_an_adaptive_file_verifies_against_the_full_reference_at_its_simulated_cells(tmp_path):
    from rimroll.study import compare, reference
    from rimroll.study.cli import main
    from rimroll.study.io import open_result

    assert main(["run", "fig12", "--quick", "--set", "adaptive=true", "--set", "adaptive_coarse=4", "--out",
                 str(tmp_path), "--no-progress"]) == 0
    ds = open_result(tmp_path / "fig12.nc")
    ref = open_result(reference.reference_path("fig12", grid="quick"))
    report = compare.compare(ds, ref)
    assert report.ok, compare.format_report(report, "adaptive", "reference")
    filled = int((ds["refine_level"] == -1).sum())
    t_end = next(v for v in report.variables if v.name == "t_end")
    outcome = next(v for v in report.variables if v.name == "outcome")
    assert filled > 0 and outcome.n_compared == report.n_common and t_end.n_compared <= report.n_common - filled


def test_the_cost_model_of_an_adaptive_map_is_a_fraction_of_the_full_one():
    from rimroll.study import registry, run_notices
    from rimroll.study.plan import make_plan

    for name in ("fig12", "outcome-cube", "continuation"):
        study = registry.get(name)
        full = run_notices.core_seconds(make_plan(study, True, {"adaptive": False}))
        for coarse, factor in ((8, 3 / 8), (64, 3 / 64), (2, 1.0)):
            plan = make_plan(study, True, {"adaptive": True, "adaptive_coarse": coarse})
            assert run_notices.core_seconds(plan) == pytest.approx(factor * full), (name, coarse)
