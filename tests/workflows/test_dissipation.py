"""The ``dissipation-models`` study: the periodic islands of Figs. 11-13 under each dissipation model."""

from __future__ import annotations

import numpy as np
import pytest
import xarray as xr

from rimroll import solver
from rimroll.solver.engine import outcomes
from rimroll.solver.physics import rolling
from rimroll.workflows import dissipation


@pytest.fixture(scope="module")
def quick(tmp_path_factory):
    from rimroll.study.cli import main

    out = tmp_path_factory.mktemp("dissipation")
    assert main(["run", "dissipation-models", "--quick", "--out", str(out), "--no-progress"]) == 0
    assert (out / "dissipation-models.png").stat().st_size > 10_000
    return xr.open_dataset(out / "dissipation-models.nc")


def test_the_equivalence_matches_the_closed_form_on_the_steady_motions():
    """On a steady motion (omega1 = 0) the linear (83) power is (1+j) m r^2 k omega3^2 (rolling) and
    j m r^2 k omega2^2 (drilling); the Coulomb ones c_r F2 |omega3| and c_d F2 |omega2|; air drag
    1/2 rho_air C_D pi r^2 (r |omega3|)^3: the factors follow by hand."""
    p = solver.Params()
    states = dissipation.reference_states(p)
    F2 = np.array([rolling.normal_force(b, 0.0, w3, p.as_array()) for b, _, _, w3 in states])
    w2, w3 = states[:, 2], states[:, 3]
    mr2 = p.m * p.r ** 2
    f = dissipation.equivalence(p)
    assert f["c_r"] == pytest.approx((1 + p.j) * mr2 * np.mean(w3 ** 2) / np.mean(F2 * np.abs(w3)), rel=1e-6)
    assert f["c_d"] == pytest.approx(p.j * mr2 * np.mean(w2 ** 2) / np.mean(F2 * np.abs(w2)), rel=1e-6)
    drag = 0.5 * p.C_D * np.pi * p.r ** 2 * np.mean(np.abs(p.r * w3) ** 3)
    assert f["rho_air"] == pytest.approx(mr2 * np.mean((1 + p.j) * w3 ** 2 + p.j * w2 ** 2) / drag, rel=1e-6)
    # the steady motions are those of the paper's sections: omega2 = 35, 65, 105 1/s at omega3 = 10 1/s
    assert np.allclose(w2, dissipation.PAPER_OMEGA2) and np.all((states[:, 0] > 0.8) & (states[:, 0] < 1.8))


def test_every_island_state_has_one_fate_and_the_fractions_add_up(quick):
    ds = quick
    assert set(ds["model"].values) == set(dissipation.MODELS) and list(ds["island"].values) == list(dissipation.ISLANDS)
    cells = ds["island_cells"]
    assert (cells.sel(island="rolling_only") > 0).all()
    total = sum(ds[f"fraction_{name}"] for name, _ in dissipation.FRACTIONS)
    np.testing.assert_allclose(total.where(cells > 0).fillna(1.0), 1.0, atol=1e-12)  # no state failed
    assert (ds["fraction_periodic"].sel(k_equivalent=0.0) == 1).all()  # no dissipation: the island itself
    assert (ds["fraction_periodic"].sel(k_equivalent=[0.02, 0.06]) == 0).all()  # dissipation ends periodicity
    inside = ds["fate"] != dissipation.OUTSIDE
    assert (inside == inside.isel(model=0)).all()  # every model runs the same island states
    assert float(ds["t_on_rim"].max()) <= float(ds.attrs["setting_t_max_dissipative"])


@pytest.mark.slow  # ~40 s on 2 cores
def test_a_models_fates_are_those_of_its_own_scene_kernel(quick):
    """The study runs every model through the kernel with all three load terms; a model's states run
    in the scene of its own parameters alone (its own compiled kernel) give the same outcomes and
    times to the last bit."""
    one = quick.sel(omega2=65.0, k_equivalent=0.02, island="slipping", model="coulomb_drilling")
    inside = one["fate"].values != dissipation.OUTSIDE
    b, w = np.meshgrid(one["beta"].values, one["omega1"].values, indexing="ij")
    states = np.stack([b[inside], w[inside], np.full(inside.sum(), 65.0), np.full(inside.sum(), 10.0)], -1)
    p = solver.Params(mu=1.0, c_d=float(one["model_c_d"]))  # the models run with slipping (mu_slip = 1)
    assert float(one["model_c_r"]) == 0 and float(one["model_rho_air"]) == 0
    own = solver.simulate(states, p, t_max=60.0, workers=1)
    np.testing.assert_array_equal(own["outcome"], one["fate"].values[inside])
    np.testing.assert_array_equal(own["t_end"], one["t_on_rim"].values[inside])


def test_the_models_disagree_where_the_paper_says_they_might(quick):
    """The answer to Sect. 5.3's question at the quick resolution: on the Fig. 11 island (omega2 = 35
    1/s) the rolling resistances put every state in, the drilling resistances every state out."""
    f = quick.sel(omega2=35.0, k_equivalent=0.02)
    assert (f["fraction_fall_in"].sel(model=["linear_rolling", "coulomb_rolling"]) == 1).all()
    assert (f["fraction_fall_out"].sel(model=["linear_drilling", "coulomb_drilling"]) == 1).all()


def test_unknown_model_is_a_clear_error():
    with pytest.raises(ValueError, match="unknown dissipation model 'viscous'; known: linear_rolling"):
        dissipation.model_params("viscous", 0.02, solver.Params(), {})


@pytest.mark.slow  # ~30 s on 2 cores
def test_outcome_cube_sweeps_a_terms_strength(tmp_path):
    """Any term's parameter is a sweep axis of outcome-cube (here Coulomb rolling resistance c_r [m])."""
    from rimroll.study.cli import main

    assert main(["run", "outcome-cube", "--quick", "--set", "mu=inf", "--set", "k_r=0", "--set", "k_d=0",
                 "--set", "c_r=0,0.002", "--set", "omega2=65", "--out", str(tmp_path), "--no-progress"]) == 0
    ds = xr.open_dataset(tmp_path / "outcome-cube.nc")
    assert ds["c_r"].values.tolist() == [0.0, 0.002] and ds["c_r"].attrs["units"] == "m"
    periodic = (ds["outcome"] == outcomes.PERIODIC_ROLLING).sum(("beta", "omega1"))
    assert int(periodic.sel(c_r=0.0)) > 0 and int(periodic.sel(c_r=0.002)) == 0  # dissipative: no periodic orbit
