"""Global dynamics (paper Sect. 4): Fig. 9 stability map, Theorem 1 solution types, Props. 4 and 6,
and the conservation of E, P_I, P_II along rolling trajectories."""

from __future__ import annotations

import numpy as np
import pytest
import xarray as xr

from rimroll import solver
from rimroll.solver.analysis import floquet, steady, trajectory
from rimroll.solver.analysis import solution_types as st
from rimroll.study.cli import main

P_ROLL = solver.Params(mu=float("inf"))
STUDIES = ("fig9", "solution-types", "invariants")


@pytest.fixture(scope="module")
def results(tmp_path_factory):
    out = tmp_path_factory.mktemp("global")
    for name in STUDIES:
        assert main(["run", name, "--quick", "--out", str(out), "--no-progress"]) == 0
    return out


def _open(results, name):
    return xr.open_dataset(results / f"{name}.nc")


# ----------------------------------------------------------------------------- files
@pytest.mark.parametrize("name", STUDIES)
def test_quick_files_are_cf(results, name):
    assert (results / f"{name}.png").read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    with _open(results, name) as ds:
        for var in [*ds.data_vars.values(), *ds.coords.values()]:
            assert var.attrs.get("units") and var.attrs.get("long_name"), var.name
            if var.dtype.kind in "iu" and var.name in ds.data_vars:  # categorical (a scalar coordinate: a count)
                assert len(var.attrs["flag_values"]) == len(var.attrs["flag_meanings"].split())
                assert set(np.unique(var.values)) <= set(var.attrs["flag_values"].tolist())
        assert ds.attrs["study"] == name


# ----------------------------------------------------------------------------- Fig. 9
def _cell(ds, x, j):
    return ds.sel(rho_over_R=x, j=j, method="nearest")


def test_fig9_axes_cover_the_relevant_range(results):
    p = solver.Params()
    with _open(results, "fig9") as ds:
        assert ds.sizes == {"rho_over_R": 40, "j": 30}
        x, j = ds["rho_over_R"].values, ds["j"].values
        assert 0 < x.min() and x.max() < 1 - p.a / p.R
        assert 0 < j.min() and j.max() == pytest.approx(2 / 3)
        assert ds["rho_over_R"].attrs["units"] == "1" and ds["j"].attrs["units"] == "1"


def test_fig9_standard_ball_unstable_small_ball_or_small_j_stable(results):
    p = solver.Params()
    with _open(results, "fig9") as ds:
        assert int(_cell(ds, p.rho / p.R, p.j)["stable"]) == 0  # paper: "the standard ball is unstable"
        # small rho/R or small j: stable (paper Sect. 4.3). Not (0.05, 0.3): the parametric
        # resonance tongue of (62) that starts at j = 1/3 (sqrt(j/(1+j)) = 1/2) on rho/R = 0 is there.
        for x, j in ((0.05, 0.15), (0.15, 0.6), (0.5, 0.05)):
            cell = _cell(ds, x, j)
            assert int(cell["stable"]) == 1, (x, j, float(cell["trace_M"]))


def test_fig9_multipliers_consistent(results):
    with _open(results, "fig9") as ds:
        np.testing.assert_allclose(ds["abs_mu1"] * ds["abs_mu2"], 1.0, atol=1e-12)
        assert np.all(ds["abs_mu1"] <= ds["abs_mu2"])
        assert np.array_equal(ds["stable"].values == 1, np.abs(ds["trace_M"].values) <= 2)
        stable = ds["stable"].values == 1
        np.testing.assert_allclose(ds["abs_mu2"].values[stable], 1.0, atol=1e-12)
        assert np.all(ds["abs_mu2"].values[~stable] > 1)
        c = _cell(ds, 0.3, 0.4)
        assert float(c["trace_M"]) == pytest.approx(float(floquet.trace(float(c["rho_over_R"]), float(c["j"]))),
                                                    rel=1e-12)


# ----------------------------------------------------------------------------- Prop. 6
def _pendulum_state(beta, energy_over_mgrho, sign=1.0):
    """State with omega2 = omega3 = 0 and E = energy_over_mgrho * m g rho."""
    p = P_ROLL
    kin = (energy_over_mgrho - np.sin(beta)) * p.m * p.g * p.rho
    w1 = sign * np.sqrt(2 * kin / (p.m * (1 + p.j) * p.r**2))
    return np.array([beta, w1, 0.0, 0.0])


@pytest.mark.parametrize("sign", [1.0, -1.0])
def test_prop6_rotating_pendulum_keeps_sign_and_is_non_periodic(sign):
    x0 = _pendulum_state(0.4, 1.05, sign)
    assert solver.invariants(x0, P_ROLL)["E"] > P_ROLL.m * P_ROLL.g * P_ROLL.rho
    t = np.linspace(0, 5, 2001)
    traj = trajectory.rolling_trajectory(x0, P_ROLL, t, rtol=1e-10)
    assert np.all(np.sign(traj[:, 1]) == sign)
    assert np.ptp(traj[:, 0]) > 2 * np.pi  # it goes round the rim's cross-section
    np.testing.assert_array_equal(traj[:, 2:], 0.0)
    assert st.solution_type(x0, P_ROLL) == st.NON_PERIODIC_PENDULUM


def test_prop6_swinging_pendulum_is_periodic():
    x0 = _pendulum_state(0.4, 0.9)
    res = st.classify(x0[None], P_ROLL, t_max=10.0)
    assert res["type"][0] == st.PERIODIC
    t = np.linspace(0, 2 * res["half_period"][0], 801)
    traj = trajectory.rolling_trajectory(x0, P_ROLL, t, rtol=1e-10)
    assert traj[:, 1].min() < 0 < traj[:, 1].max()


# ----------------------------------------------------------------------------- Prop. 4
@pytest.mark.parametrize("x0", [[0.3, 5.0, 20.0, 10.0], [-1.0, -3.0, -40.0, 25.0]])
def test_prop4_two_transversal_zeros_give_period_2_dt(x0):
    x0 = np.array(x0)
    times, rates, status = trajectory.omega1_zeros(x0, P_ROLL, 20.0, n_zeros=2, rtol=1e-12, atol=1e-13)
    assert status == 0 and times.size == 2 and np.all(np.abs(rates) > 1e-3)
    period = 2 * (times[1] - times[0])
    back = trajectory.rolling_trajectory(x0, P_ROLL, [period], rtol=1e-12, atol=1e-13)[0]
    np.testing.assert_allclose(back, x0, rtol=0, atol=1e-7 * (1 + np.abs(x0).max()))
    res = st.classify(x0, P_ROLL)
    assert res["type"] == st.PERIODIC
    assert res["half_period"] == pytest.approx(times[1] - times[0], rel=1e-7)


# ----------------------------------------------------------------------------- equilibria
def test_steady_motions_are_equilibria():
    b = np.array([0.6, -2.0, 2.5, 1.0])
    w = np.array([10.0, -30.0, 15.0, -50.0])
    x = steady.steady_state(b, w, P_ROLL)
    np.testing.assert_array_equal(st.solution_type(x, P_ROLL), st.NONTRIVIAL_EQUILIBRIUM)
    trivial = np.stack([steady.trivial_state(1, 5.0, P_ROLL), steady.trivial_state(-1, 0.0, P_ROLL)])
    np.testing.assert_array_equal(st.solution_type(trivial, P_ROLL), st.TRIVIAL_EQUILIBRIUM)


def test_near_stable_steady_motion_is_periodic():
    assert steady.stability(0.6, 10.0, P_ROLL) < 0  # a centre (Prop. 13)
    x = steady.steady_state(0.6, 10.0, P_ROLL)
    x[1] = 0.3
    assert st.solution_type(x, P_ROLL) == st.PERIODIC


def test_dissipative_parameters_are_refused(tmp_path):
    with pytest.raises(ValueError, match="k_r"):
        st.solution_type(np.zeros(4), solver.Params(k_r=0.02))
    assert main(["run", "solution-types", "--quick", "--out", str(tmp_path), "--set", "k_r=0.02"]) == 2


# ----------------------------------------------------------------------------- studies
def test_solution_types_quick_run(results):
    with _open(results, "solution-types") as ds:
        assert ds.sizes == {"sample": 40}
        types = ds["type"].values
        counts = np.bincount(types, minlength=len(st.TYPE_FLAG_VALUES))
        assert counts.sum() == 40
        # the quick run's mixed sample shows the types side by side (a box's states: 40 periodic of 40)
        assert (counts > 0).sum() >= 5 and counts[st.PERIODIC] < 40
        assert counts[st.UNDETERMINED] <= 2
        periodic = types == st.PERIODIC
        assert np.all(ds["half_period"].values[periodic] > 0)
        assert np.all(np.isnan(ds["half_period"].values[~periodic]))


def test_invariants_conserved_within_100_rtol(results):
    with _open(results, "invariants") as ds:
        rtol = float(ds.attrs["setting_rtol"])
        assert ds.sizes == {"trajectory": 3, "t": 101}
        assert ds["t"].attrs["units"] == "s"
        for name in ("rel_change_E", "rel_change_P_I", "rel_change_P_II"):
            assert float(np.abs(ds[name]).max()) <= 100 * rtol, name
        assert np.all(ds["rel_change_E"].isel(t=0) == 0)
        assert float(np.ptp(ds["omega1_t"].values, axis=1).min()) > 0.1  # the states do move
