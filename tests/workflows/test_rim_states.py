"""The ``rim-states`` study: its captured states against the rim engine run on its own, a symmetry of the
shot, and the placement on Fig. 8 against the closed forms of the steady motions."""

from __future__ import annotations

import numpy as np
import pytest

from rimroll import solver
from rimroll.solver import shots
from rimroll.solver.analysis import steady
from rimroll.workflows import rim_states as rs


def _grid(**changes):
    s = {**rs.SETTINGS, "distance": 4.19, "backspin": 18.8496, "sidespin": 0.0, **changes}
    dv, angle, az = (np.linspace(-0.3, 0.3, 13), np.linspace(44.0, 60.0, 9), np.linspace(-2.0, 2.0, 9))
    coords = np.meshgrid(dv, angle, az, indexing="ij")
    return s, rs._compute(coords, solver.Params(), s)


@pytest.fixture(scope="module")
def grid():
    return _grid()


def test_rim_outcome_is_the_engines_outcome_of_the_captured_state(grid):
    """A ball captured rolling (slip below 1e-9 m/s) has the outcome ``solver.simulate`` gives its captured state on
    the rim: the maps of Figs. 11-13 read at that state."""
    _, out = grid
    rolling = np.isfinite(out["beta_cap"]) & (out["slip_cap"] < 1e-9)
    assert rolling.sum() >= 3
    states = np.stack([out[k][rolling] for k in ("beta_cap", "omega1_cap", "omega2_cap", "omega3_cap")], axis=-1)
    p = shots.params_for("paper")
    res = solver.simulate(states, p, t_max=float(rs.SETTINGS["t_max_shot"]) + 60.0)
    assert np.array_equal(res["outcome"], out["rim_outcome"][rolling]), (res["outcome"], out["rim_outcome"][rolling])


def test_a_shot_in_the_plane_of_the_axis_has_no_circulation():
    """No sideways aim and no sidespin: the shot stays in the vertical plane through the hoop's axis, so
    a captured ball has omega2 = omega3 = 0 (mirror symmetry y -> -y)."""
    s = {**rs.SETTINGS, "distance": 4.19, "backspin": 18.8496, "sidespin": 0.0}
    coords = np.meshgrid(np.linspace(-0.3, 0.3, 25), np.linspace(44.0, 60.0, 17), np.array([0.0]), indexing="ij")
    out = rs._compute(coords, solver.Params(), s)
    cap = np.isfinite(out["beta_cap"])
    assert cap.any()
    assert np.allclose(out["omega2_cap"][cap], 0.0, atol=1e-9)
    assert np.allclose(out["omega3_cap"][cap], 0.0, atol=1e-9)


def test_placement_on_fig8(grid):
    """position: the band of beta of A, B, C; region: realisable only inside its position's band, and
    never where (59)'s kinetic energy exceeds a throw at v_throw; omega20 the closed form (48)."""
    s, out = grid
    beta, w3 = out["beta_cap"], out["omega3_cap"]
    cap = np.isfinite(beta)
    b = (beta[cap] + np.pi) % (2 * np.pi) - np.pi
    expect = np.where((b > 0) & (b < np.pi / 2), 1, np.where((b < 0) & (b > -np.pi / 2), 2, 3))
    assert np.array_equal(out["position"][cap], expect)
    assert np.all(out["position"][~cap] == 0) and np.all(out["region"][~cap] == 0)
    real = out["region"] > 0
    assert np.array_equal(out["region"][real], out["position"][real])
    p = shots.params_for("paper")
    with np.errstate(invalid="ignore", divide="ignore"):  # (48)
        w20 = ((1 + p.j) * w3 * np.sin(beta) / (p.j * np.cos(beta))
               - p.g * (p.R - p.rho * np.cos(beta)) / (p.j * p.r**2 * w3))
    energy = np.sqrt(p.j * p.r**2 * w20**2 + (1 + p.j) * p.r**2 * w3**2)
    assert np.all(energy[real] <= s["v_throw"])
    assert np.allclose(out["omega20_cap"][cap], w20[cap], rtol=1e-12, equal_nan=True)
    assert np.array_equal(steady.region_of(beta[cap]), out["position"][cap])
