"""Outcome sections fig11-fig13 (paper Figs. 11-13) on their --quick grids: the paper's statements on them
(Sect. 5.2.3, 5.3.2), as listed in docs/outcome-studies.md."""

from __future__ import annotations

import numpy as np
import pytest
import xarray as xr
from scipy import ndimage

from rimroll import solver
from rimroll.solver.engine import outcomes

ROLL, SLIP, DRILL, RRES = range(4)


@pytest.fixture(scope="module")
def sections(tmp_path_factory):
    from rimroll.study.cli import main

    out = tmp_path_factory.mktemp("outcomes")
    for name in ("fig11", "fig12", "fig13"):
        assert main(["run", name, "--quick", "--out", str(out), "--no-progress"]) == 0
    return {name: xr.open_dataset(out / f"{name}.nc") for name in ("fig11", "fig12", "fig13")}


def test_files_carry_scenes_every_result_field_and_t_max(sections):
    ds = sections["fig12"]
    assert ds["outcome"].dims == ("scene", "beta", "omega1")
    assert np.isinf(ds["mu"][ROLL]) and (ds["mu"][1:] == 1.0).all()
    assert float(ds["k_d"][DRILL]) == 0.02 and float(ds["k_r"][RRES]) == 0.02
    assert float(ds["t_max"][DRILL]) == 60.0 and float(ds["t_max"][RRES]) == 60.0
    for name in ("outcome", "t_end", "f2_min", "half_period", "revolutions", "slip_phases", "slip_time",
                 "energy_drift", "n_steps", "beta_end", "omega1_end", "omega2_end", "omega3_end", "status"):
        assert "units" in ds[name].attrs and "long_name" in ds[name].attrs
    assert ds["outcome"].attrs["flag_meanings"].split() == ["fall_in", "fall_out", "periodic_rolling",
                                                          "on_rim_at_t_max", "steady_motion"]
    assert ds.attrs["setting_omega2"] == 65.0
    assert (ds["status"] == outcomes.OK).all()


def test_scenes_are_selected_by_label(sections):
    ds = sections["fig12"]
    assert list(ds["scene"].values) == ["rolling_only", "slipping", "drilling", "rolling_resistance"]
    assert ds["scene"].dtype.kind in "UO"
    slipping = ds.sel(scene="slipping")
    assert float(slipping["mu"]) == 1.0 and float(slipping["k_r"]) == 0.0 and float(slipping["k_d"]) == 0.0
    assert (slipping["outcome"] == ds["outcome"].isel(scene=SLIP)).all()
    assert float(ds.sel(scene="drilling")["k_d"]) == 0.02 and float(ds.sel(scene="rolling_resistance")["k_r"]) == 0.02
    assert np.isinf(float(ds["mu"].sel(scene="rolling_only")))


def test_cf_xarray_reads_the_flags(sections):
    import cf_xarray  # noqa: F401  (the test extra installs it; registers the .cf accessor)
    ds = sections["fig11"]
    codes = dict(zip(ds["outcome"].attrs["flag_meanings"].split(), ds["outcome"].attrs["flag_values"].tolist()))
    periodic = ds["outcome"].cf == "periodic_rolling"
    assert periodic.any() and (periodic == (ds["outcome"] == codes["periodic_rolling"])).all()
    assert (ds["status"].cf == "ok").all()
    assert ds["status"].attrs["standard_name"] == "status_flag"  # the CF standard name of a status flag
    assert ds.attrs["references"] and ds.attrs["source"].startswith("rimroll ")
    assert "dp5 at rtol 1e-08" in ds.attrs["source"]


def test_grid_matches_the_documented_outcome_grid(sections):
    ds = sections["fig11"]
    assert ds["beta"].values[[0, -1]].tolist() == [0.8, 1.8]
    assert ds["omega1"].values[[0, -1]].tolist() == [-20.0, 20.0]
    assert ds.attrs["setting_omega3"] == 10.0


def test_fig11_slipping_barely_changes_the_diagram(sections):
    out = sections["fig11"]["outcome"].values
    assert (out[ROLL] == outcomes.PERIODIC_ROLLING).any()
    assert np.mean(out[ROLL] != out[SLIP]) < 0.02


@pytest.mark.parametrize("name", ["fig12", "fig13"])
def test_periodic_region_is_embedded_in_fall_out(sections, name):
    out = sections[name]["outcome"].values[SLIP]
    periodic = out == outcomes.PERIODIC_ROLLING
    assert periodic.any()
    ring = ndimage.binary_dilation(periodic) & ~periodic
    assert (out[ring] == outcomes.FALL_OUT).all()


@pytest.mark.parametrize("name", ["fig11", "fig12"])
def test_drilling_sends_former_periodic_states_out_rolling_resistance_in(sections, name):
    out = sections[name]["outcome"].values
    former = out[SLIP] == outcomes.PERIODIC_ROLLING
    assert former.sum() >= 5
    assert np.mean(out[DRILL][former] == outcomes.FALL_OUT) >= 0.9
    assert np.mean(out[RRES][former] == outcomes.FALL_IN) >= 0.9


def test_fig13_dissipation_sends_former_periodic_states_out(sections):
    out = sections["fig13"]["outcome"].values
    former = out[SLIP] == outcomes.PERIODIC_ROLLING
    assert former.any()
    assert (out[DRILL][former] == outcomes.FALL_OUT).all() and (out[RRES][former] == outcomes.FALL_OUT).all()


def test_dissipative_scenes_have_no_periodic_states_and_stay_long_near_the_former_orbits(sections):
    ds = sections["fig11"]
    out = ds["outcome"].values
    assert not (out[DRILL:] == outcomes.PERIODIC_ROLLING).any()
    former = out[SLIP] == outcomes.PERIODIC_ROLLING
    t_end = ds["t_end"].values
    assert np.median(t_end[DRILL][former]) > 5 * np.median(t_end[DRILL][~former])


def test_stored_values_equal_a_direct_simulate_call(sections):
    ds = sections["fig12"]
    i, k = 7, 20
    state = [float(ds["beta"][i]), float(ds["omega1"][k]), 65.0, 10.0]
    direct = solver.simulate(np.array([state]), solver.Params(mu=1.0), t_max=20.0)
    assert direct["outcome"][0] == ds["outcome"].values[SLIP, i, k]
    assert direct["t_end"][0] == pytest.approx(float(ds["t_end"][SLIP, i, k]), rel=1e-12)


def test_former_periodic_marks_both_islands_and_counts_their_fates(sections):
    """``former_periodic`` outlines the periodic islands of both conservative scenes, and its attributes
    count what each dissipative scene does with each island's states (recounted here from the outcomes):
    Sect. 5.3.2's 'small rolling resistance makes former periodic states fall in' holds for the slipping
    island; the rolling-only island, larger, partly falls out."""
    ds = sections["fig12"]
    var = ds["former_periodic"]
    assert var.dims == ("scene", "beta", "omega1") and (var == var.isel(scene=0)).all()
    assert var.attrs["flag_meanings"].split() == ["none", "rolling_only_island", "slipping_island", "both_islands"]
    assert var.attrs["fate_order"] == "fall_in fall_out other"
    out = ds["outcome"].values
    flags = var.values[0]
    islands = {"rolling_only": out[ROLL] == outcomes.PERIODIC_ROLLING,
               "slipping": out[SLIP] == outcomes.PERIODIC_ROLLING}
    assert ((flags & 1) == 1).tolist() == islands["rolling_only"].tolist()
    assert ((flags & 2) == 2).tolist() == islands["slipping"].tolist()
    for scene, k in (("drilling", DRILL), ("rolling_resistance", RRES)):
        for island, mask in islands.items():
            counts = var.attrs[f"fate_counts_{scene}_{island}"]
            fate = out[k][mask]
            expected = [(fate == outcomes.FALL_IN).sum(), (fate == outcomes.FALL_OUT).sum()]
            assert counts.tolist() == expected + [mask.sum() - sum(expected)]
            assert var.attrs[f"island_cells_{island}"] == mask.sum()
            np.testing.assert_allclose(var.attrs[f"fate_fractions_{scene}_{island}"], counts / mask.sum())
    def fr(scene, island):
        return var.attrs[f"fate_fractions_{scene}_{island}"]
    assert fr("rolling_resistance", "slipping")[0] >= 0.9 and fr("drilling", "slipping")[1] >= 0.9
    assert 0.1 <= fr("rolling_resistance", "rolling_only")[1] <= 0.5  # part of the larger island falls out
    assert not any(k.startswith("fate_counts_slipping") or k.startswith("fate_counts_rolling_only_")
                   for k in var.attrs)  # conservative scenes have no fates


def test_on_rim_reason_is_stored_with_its_flags(sections):
    ds = sections["fig12"]
    var = ds["on_rim_reason"]
    assert var.attrs["flag_meanings"].split()[:3] == ["not_on_rim", "rolling_transient", "slip_roll_cycling"]
    on = ds["outcome"] == outcomes.ON_RIM_AT_T_MAX
    assert ((var != outcomes.NOT_ON_RIM) == on).all()


def test_delta_and_slip_method_are_settings_recorded_and_used(tmp_path):
    """``--set delta=...`` (the launch speed of a slip, Sect. 5.2.2) and ``--set slip_method=...``
    reach the engine and the file: a fig12 run at delta = 1e-6 m/s records it, and its slipping scene
    equals a direct simulate call with the switching tolerances delta sets (u_stop = delta,
    u_floor = delta / 100), not the default run."""
    from rimroll.study.cli import main
    from rimroll.study.dataset import setting_of

    sets = ["--set", "n_beta=6", "--set", "n_omega1=8", "--set", "delta=1e-6", "--set", "slip_method=explicit"]
    assert main(["run", "fig12", "--quick", "--out", str(tmp_path), "--no-progress", *sets]) == 0
    with xr.open_dataset(tmp_path / "fig12.nc") as ds:
        assert float(setting_of(ds, "delta")) == 1e-6 and setting_of(ds, "slip_method") == "explicit"
        beta, omega1 = np.meshgrid(ds["beta"].values, ds["omega1"].values, indexing="ij")
        states = np.stack([beta, omega1, np.full_like(beta, 65.0), np.full_like(beta, 10.0)], axis=-1)
        switching = {"delta": 1e-6, "u_stop": 1e-6, "u_floor": 1e-8, "slip_method": "explicit"}
        direct = solver.simulate(states, solver.Params(mu=1.0), t_max=20.0, switching=switching)
        np.testing.assert_array_equal(ds["t_end"].values[SLIP], direct["t_end"])
        default = solver.simulate(states, solver.Params(mu=1.0), t_max=20.0)
        slipped = direct["slip_phases"] > 0
        assert slipped.any() and not np.array_equal(direct["t_end"][slipped], default["t_end"][slipped])
    assert main(["run", "fig12", "--quick", "--out", str(tmp_path / "bad"), "--no-progress", "--set", "delta=1"]) == 2
