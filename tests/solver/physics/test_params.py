"""solver.Params: Table 1 defaults and validation."""

import math

import numpy as np
import pytest

from rimroll import solver
from rimroll.solver.physics.params import N_PARAMS, P_MU, P_RHO


def test_table1_defaults_and_rho():
    p = solver.Params()
    assert (p.r, p.R, p.a, p.m, p.j, p.mu, p.g) == (0.12, 0.225, 0.01, 0.6, 2 / 3, 1.0, 9.81)
    assert p.rho == pytest.approx(0.13)
    assert (p.k_r, p.k_d) == (0.0, 0.0)
    arr = p.as_array()
    assert arr.shape == (N_PARAMS,) and arr[P_RHO] == pytest.approx(0.13) and arr[P_MU] == 1.0


def test_scene_flags():
    assert solver.Params(mu=math.inf).rolling_only
    assert not solver.Params().rolling_only
    assert solver.Params(k_d=0.02).dissipative and solver.Params(k_r=0.02).dissipative
    assert not solver.Params().dissipative


@pytest.mark.parametrize(
    "kwargs, name",
    [
        ({"r": 0.0}, "r"),
        ({"R": -1.0}, "R"),
        ({"a": math.inf}, "a"),
        ({"m": math.nan}, "m"),
        ({"g": 0.0}, "g"),
        ({"j": 0.0}, "j"),
        ({"mu": -0.1}, "mu"),
        ({"mu": math.nan}, "mu"),
        ({"k_r": -0.01}, "k_r"),
        ({"k_d": math.inf}, "k_d"),
        ({"j": "heavy"}, "j"),
    ],
)
def test_bad_values_name_parameter_value_and_range(kwargs, name):
    with pytest.raises(ValueError) as err:
        solver.Params(**kwargs)
    msg = str(err.value)
    assert f"{name}=" in msg
    assert repr(next(iter(kwargs.values()))) in msg or "real number" in msg
    assert "allowed" in msg or "must" in msg


def test_geometry_needs_rho_below_R():
    with pytest.raises(ValueError, match=r"rho = r \+ a .* must be < R"):
        solver.Params(r=0.22, a=0.01, R=0.225)


def test_infinite_mu_allowed_and_numpy_scalars_accepted():
    p = solver.Params(mu=float("inf"), j=np.float32(0.4), m=np.int64(1))
    assert math.isinf(p.mu) and isinstance(p.j, float) and p.m == 1.0


def test_from_rho_over_R_keeps_R_and_a():
    p = solver.Params.from_rho_over_R(0.5)
    assert p.R == 0.225 and p.a == 0.01 and p.rho == pytest.approx(0.1125)
    with pytest.raises(ValueError, match="rho_over_R"):
        solver.Params.from_rho_over_R(0.02)  # r = rho - a < 0
    with pytest.raises(ValueError, match="rho_over_R"):
        solver.Params.from_rho_over_R(1.2)
