"""``study trace`` and ``solver.analysis.phase_trace``: one trajectory, sampled from the dense output of each phase.

The trace is an independent integration (scipy DOP853, phase by phase) of the same physics as
``solver.simulate``; it must end where simulate ends, with the same outcome.
"""

from __future__ import annotations

import numpy as np
import pytest
import xarray as xr

from rimroll import solver
from rimroll.solver.analysis.phase_trace import SLIPPING, trace
from rimroll.solver.engine import outcomes
from rimroll.study import rim_trace as trace_module
from rimroll.study.cli import main

SCENES = {
    "rolling_only": (solver.Params(mu=float("inf")), 20.0),
    "slipping": (solver.Params(mu=1.0), 20.0),
    "drilling": (solver.Params(mu=1.0, k_d=0.02), 60.0),
    "rolling_resistance": (solver.Params(mu=1.0, k_r=0.02), 60.0),
}
STATES = np.array([[1.1, 2.0, 65.0, 10.0], [1.2, 0.5, 65.0, 10.0], [1.0, 5.0, 35.0, 10.0], [1.5, -3.0, 105.0, 10.0]])


@pytest.mark.parametrize("scene", list(SCENES))
def test_trace_ends_where_simulate_ends_with_the_same_outcome(scene):
    params, t_max = SCENES[scene]
    ref = solver.simulate(STATES, params, t_max=t_max, rtol=1e-10, atol=1e-12)
    for i, x in enumerate(STATES):
        tr = trace(x, params, t_max=t_max, n=200)
        assert tr["outcome"] == ref["outcome"][i], (scene, x)
        assert tr["t_end"] == pytest.approx(ref["t_end"][i], rel=1e-6, abs=1e-9)
        assert tr["slip_phases"] == ref["slip_phases"][i]
        assert tr["t"][0] == 0.0 and tr["t"][-1] == pytest.approx(tr["t_end"], abs=1e-12)
        assert tr["event_kind"][-1] == tr["reason"]
        if tr["outcome"] in (outcomes.FALL_IN, outcomes.FALL_OUT):
            assert tr["F2"][-1] == pytest.approx(0.0, abs=1e-6)  # it ends where the contact is lost
        assert (tr["beta"][-1], tr["omega1"][-1]) == pytest.approx(
            (ref["beta_end"][i], ref["omega1_end"][i]), rel=1e-5, abs=1e-6)


def test_energy_is_flat_along_a_conservative_rolling_trace():
    params = solver.Params(mu=float("inf"))
    tr = trace(STATES[1], params, t_max=20.0, rtol=1e-10, atol=1e-12)
    assert tr["outcome"] == outcomes.PERIODIC_ROLLING
    e = tr["energy"]
    assert np.max(np.abs(e - e[0])) / abs(e[0]) < 1e-8
    # and it moves: the state is not a steady motion
    assert np.ptp(tr["omega1"]) > 0.1


def test_slip_phases_are_marked_and_use_all_the_friction():
    params, t_max = SCENES["slipping"]
    tr = trace(STATES[0], params, t_max=t_max)
    slip = tr["phase"] == SLIPPING
    assert slip.any() and (~slip).any()
    np.testing.assert_allclose(tr["friction_use"][slip], 1.0)
    assert np.all(tr["friction_use"][~slip] <= 1.0 + 1e-6)  # rolling stays inside the cone (39)
    assert list(tr["event_kind"]).count("slip_onset") == tr["slip_phases"]


def test_study_trace_writes_file_and_figure_and_picks_a_map_point(tmp_path, capsys):
    assert main(["trace", "--state", "1.2,0.5,65,10", "--set", "mu=inf", "--out", str(tmp_path)]) == 0
    ds = xr.open_dataset(tmp_path / "trace.nc")
    assert ds.attrs["outcome_meaning"] == "periodic_rolling" and ds.attrs["reason"] == "periodic"
    assert float(ds["time"][-1]) == pytest.approx(ds.attrs["t_end"])
    for name in ("beta", "F2", "friction_use", "slip_speed", "energy", "phase", "event_time"):
        assert ds[name].attrs["units"] and ds[name].attrs["long_name"]
    assert (tmp_path / "trace.png").is_file()
    assert main(["plot", str(tmp_path / "trace.nc")]) == 0
    # a point of an outcome map: the file's scene parameters, t_max, omega2 and omega3
    assert main(["run", "fig12", "--quick", "--out", str(tmp_path), "--no-progress"]) == 0
    assert main(["trace", str(tmp_path / "fig12.nc"), "--at", "omega1=0.5,beta=1.2,scene=rolling_resistance",
                 "--out", str(tmp_path), "--name", "point"]) == 0
    pt = xr.open_dataset(tmp_path / "point.nc")
    fig12 = xr.open_dataset(tmp_path / "fig12.nc")
    cell = fig12.sel(omega1=0.5, beta=1.2, method="nearest").isel(scene=3)
    assert pt.attrs["param_k_r"] == 0.02 and pt.attrs["param_mu"] == 1.0 and pt.attrs["t_max"] == 60.0
    assert (pt.attrs["initial_beta"], pt.attrs["initial_omega1"]) == (float(cell["beta"]), float(cell["omega1"]))
    assert pt.attrs["initial_omega2"] == 65.0
    assert pt.attrs["outcome"] == int(cell["outcome"])  # same state and scene as the map's cell
    capsys.readouterr()


@pytest.mark.parametrize("argv, words", [
    (["trace"], "either --state"),
    (["trace", "--state", "1,2,3"], "four finite numbers"),
    (["trace", "--state", "1,2,65,10", "--set", "mu=-1"], "mu"),
    (["trace", "--state", "1,2,65,10", "--set", "nope=1"], "KEY=VALUE"),
    (["trace", "--state", "1,2,65,10", "--rtol", "1"], "--rtol"),
    (["trace", "--state", "-1.57,0,0,0"], "--state=-1.57,0,0,0"),  # argparse took the value for an option
])
def test_trace_user_errors_are_one_line(argv, words, capsys, tmp_path):
    assert main([*argv, "--out", str(tmp_path)]) == 2
    err = capsys.readouterr().err.strip()
    assert err.startswith("study: error:") and words in err and "\n" not in err


def test_periods_follow_a_periodic_orbit_repeating(tmp_path, capsys):
    """--periods N continues past the second omega1 zero that decides periodic rolling: the state
    repeats after each period, every piece measures the same half period, and the outcome and t_end
    stay simulate's."""
    assert main(["trace", "--state", "1.2,0.5,65,10", "--set", "mu=inf", "--periods", "2", "--out", str(tmp_path),
                 "--samples", "800"]) == 0
    assert "followed 2 more periods" in capsys.readouterr().out
    ds = xr.open_dataset(tmp_path / "trace.nc")
    half = ds.attrs["half_period"]
    assert ds.attrs["reason"] == "periodic" and ds.attrs["periods_followed"] == 2
    np.testing.assert_allclose(ds.attrs["half_periods_followed"], half, rtol=1e-8)
    t = ds["time"].values
    assert t[-1] == pytest.approx(ds.attrs["t_followed"]) == pytest.approx(ds.attrs["t_end"] + 4 * half, rel=1e-8)
    assert np.all(np.diff(t) > 0)
    for name in ("beta", "omega1", "omega2", "omega3", "F2"):
        v = ds[name].values
        for t0 in (0.05, 0.2):  # one period on, and two, the state is the same
            for k in (1, 2):
                assert np.interp(t0 + 2 * k * half, t, v) == pytest.approx(np.interp(t0, t, v), rel=1e-4, abs=1e-4)
    assert main(["trace", "--state", "1.2,0.5,65,10", "--periods", "-1", "--out", str(tmp_path), "--force"]) == 2


@pytest.mark.parametrize("state", ["0,0,0,0", "1.2,50,65,10", "1.2,-200,65,10", "1.2,1e11,65,10"])
def test_a_state_that_leaves_the_rim_at_once_is_a_trace_of_one_sample(state, tmp_path, capsys):
    """F2 <= 0 at the start (or a slip onset that loses the contact at t = 0): the trace ends at
    t_end = 0 with no phase; the file holds the initial state at t = 0 and its figure says so."""
    assert main(["trace", "--state", state, "--out", str(tmp_path)]) == 0
    assert "leaves the rim at t = 0" in capsys.readouterr().out
    ds = xr.open_dataset(tmp_path / "trace.nc")
    assert ds.attrs["reason"] == "fall" and ds.attrs["t_end"] == 0.0
    assert ds.sizes["time"] == 1 and float(ds["time"][0]) == 0.0
    x = np.array([float(v) for v in state.split(",")])
    np.testing.assert_array_equal([float(ds[n][0]) for n in ("beta", "omega1", "omega2", "omega3")], x)
    assert float(ds["F2"][0]) <= 0.0 and list(ds["event_time"].values) == [0.0] * ds.sizes["event"]
    assert (tmp_path / "trace.png").is_file()
    assert main(["plot", str(tmp_path / "trace.nc")]) == 0  # study plot re-draws it


def test_a_failed_figure_leaves_no_file_behind(tmp_path, monkeypatch):
    """The .nc is moved into place after its figure is written: a plot that fails leaves neither
    file, and the rerun needs no --force."""
    from rimroll.study import rim_trace as study_trace

    def broken(ds):
        raise RuntimeError("the figure failed")

    argv = ["trace", "--state", "1.2,0.5,65,10", "--set", "mu=inf", "--out", str(tmp_path)]
    monkeypatch.setattr(study_trace, "figure", broken)
    with pytest.raises(RuntimeError, match="the figure failed"):
        main(argv)
    assert list(tmp_path.iterdir()) == []
    monkeypatch.undo()
    assert main(argv) == 0
    assert sorted(p.name for p in tmp_path.iterdir()) == ["trace.nc", "trace.png"]


def test_trace_picks_a_point_of_a_file_with_swept_axes(tmp_path, capsys):
    """--at selects the point on every swept axis (mu, omega2 here; k_r, k_d hold one value each);
    a swept axis it leaves out, or a value that is no number near the axis, is one line, exit 2."""
    assert main(["run", "outcome-cube", "--quick", "--set", "mu=0.5,1", "--set", "omega2=35,65", "--set", "k_r=0",
                 "--set", "k_d=0", "--set", "n_beta=3", "--set", "n_omega1=3", "--out", str(tmp_path),
                 "--no-progress"]) == 0
    cube = xr.open_dataset(tmp_path / "outcome-cube.nc")
    assert cube.sizes["mu"] == 2 and cube.sizes["omega2"] == 2
    capsys.readouterr()
    for mu in (0.5, 1.0):  # the two scenes end differently from this state: fall_out at 0.30 s, fall_in at 0.14 s
        cell = cube.sel(mu=mu, omega2=65.0, beta=0.8, omega1=0.0).squeeze()
        assert main(["trace", str(tmp_path / "outcome-cube.nc"), "--at", f"mu={mu:g},omega2=64",
                     "--at", "beta=0.9,omega1=0", "--out", str(tmp_path), "--name", f"mu{mu:g}"]) == 0
        assert f"mu={mu:g}, omega2=65, beta=0.8, omega1=0" in capsys.readouterr().out  # the grid point taken
        pt = xr.open_dataset(tmp_path / f"mu{mu:g}.nc")
        assert pt.attrs["param_mu"] == mu and pt.attrs["param_k_r"] == 0.0 and pt.attrs["t_max"] == float(cell["t_max"])
        assert [pt.attrs[f"initial_{n}"] for n in ("beta", "omega1", "omega2", "omega3")] == [0.8, 0.0, 65.0, 10.0]
        assert pt.attrs["outcome"] == int(cell["outcome"])
        assert pt.attrs["t_end"] == pytest.approx(float(cell["t_end"]), rel=1e-4)
    capsys.readouterr()
    for at, words in (("mu=1,beta=1.3,omega1=0", ("'omega2'", "(35, 65)")),
                      ("mu=1,omega2=65,beta=1.3,omega1=nan", ("omega1=nan", "(-20, 0, 20)")),
                      ("mu=1,omega2=65,beta=1.3,omega1=1e300", ("omega1=1e300", "(-20, 0, 20)")),
                      ("mu=1,omega2=65,beta=1.3,omega1=55", ("omega1=55: outside", "(-20, 0, 20)")),
                      ("mu=1,omega2=65,beta=1.3,omega1=0,mu=0.5", ("--at mu is given twice",)),
                      ("mu=inf,omega2=65,beta=1.3,omega1=0", ("mu=inf", "(0.5, 1)"))):
        assert main(["trace", str(tmp_path / "outcome-cube.nc"), "--at", at, "--out", str(tmp_path),
                     "--name", "bad"]) == 2
        err = capsys.readouterr().err.strip()
        assert err.startswith("study: error:") and all(w in err for w in words) and "\n" not in err, err
        assert not (tmp_path / "bad.nc").exists()


@pytest.mark.parametrize("name", ["../escape", "a/b", "", ".", "..", ".hidden", ".nc", "a b", "x\\y"])
def test_trace_name_is_a_plain_file_stem(name, tmp_path, capsys):
    out = tmp_path / "results"
    assert main(["trace", "--state", "1.2,0.5,65,10", "--set", "mu=inf", "--out", str(out), "--name", name]) == 2
    err = capsys.readouterr().err.strip()
    assert err.startswith("study: error: --name") and "letters, digits" in err and "\n" not in err
    assert list(tmp_path.rglob("*")) == []  # nothing written, in results/ or beside it


def test_trace_name_drops_a_trailing_nc(tmp_path, capsys):
    assert main(["trace", "--state", "1.2,0.5,65,10", "--set", "mu=inf", "--out", str(tmp_path),
                 "--name", "orbit-1.b.nc"]) == 0
    assert sorted(p.name for p in tmp_path.iterdir()) == ["orbit-1.b.nc", "orbit-1.b.png"]
    capsys.readouterr()


@pytest.mark.parametrize("state, mu", [((1.2, 0.5, 65.0, 10.0), 0.5), ((1.2, 0.5, 65.0, 10.0), float("inf"))])
def test_revolutions_slip_time_and_time_on_the_rim_in_line_file_and_figure(state, mu, tmp_path, capsys):
    """The numbers agree with solver.simulate's outputs of the same names (the compiled engine, an independent
    integration), and the sign of the revolutions is the way the centre goes round seen from above (the path
    x, y of the file): omega3 > 0 rolls clockwise, alpha falling (19)."""
    text = f"{state[0]},{state[1]},{state[2]},{state[3]}"
    assert main(["trace", "--state", text, "--set", f"mu={mu}", "--out", str(tmp_path)]) == 0
    line = capsys.readouterr().out
    ds = xr.open_dataset(tmp_path / "trace.nc")
    ref = solver.simulate([state], solver.Params(mu=mu), rtol=1e-10, atol=1e-12)
    assert ds.attrs["revolutions"] == pytest.approx(float(ref["revolutions"][0]), abs=1e-6)
    assert ds.attrs["slip_time"] == pytest.approx(float(ref["slip_time"][0]), abs=1e-6)
    assert ds.attrs["time_on_rim"] == pytest.approx(float(ref["t_end"][0]), abs=1e-6)
    turned = np.unwrap(np.arctan2(ds["y"].values, ds["x"].values))
    assert np.sign(turned[-1] - turned[0]) == np.sign(ds.attrs["revolutions"]) == -1
    assert "clockwise seen from above" in ds.attrs["revolutions_sign"]
    assert f"{ds.attrs['revolutions']:+.3f} revolutions around the rim (alpha falling: clockwise seen from above)" \
        in line and f"{ds.attrs['slip_time']:.4g} s slipping" in line
    title = trace_module.figure(ds).texts[0].get_text()  # the suptitle
    assert f"{ds.attrs['revolutions']:+.3f} revolutions around the rim" in title
