"""The steady-motion maps (paper Figs. 3-8) agree with the paper and with solver.steady."""

from __future__ import annotations

import numpy as np
import pytest
import xarray as xr

from rimroll import solver
from rimroll.solver.analysis import steady
from rimroll.study import cli_text, execute, registry
from rimroll.study.dataset import params_of
from rimroll.study.plan import make_plan


def _run(name, *sets, quick=True):
    """(Dataset, Params) of one run, as ``study run NAME [--quick] --set ...`` makes it (plan,
    fan-out, parts, assembly), read back into memory."""
    plan = make_plan(registry.get(name), quick, cli_text.setting_values(registry.get(name), sets))
    ds = execute.compute(plan, f"tests/workflows/test_steady_maps.py {name} {' '.join(sets)}", workers=2)
    assert params_of(ds) == plan.params  # the file is what its attributes say
    return ds, plan.params


def _areas(region):
    return {code: int((region == code).sum()) for code in steady.REGION_FLAG_VALUES}


@pytest.fixture(scope="module")
def fig8():
    return _run("fig8", "n_beta0=241", "n_omega30=160")


def test_fig8_three_regions_at_10_m_per_s_with_A_largest(fig8):
    ds, _ = fig8
    area = _areas(ds["region"].values)
    assert area[steady.REGION_A] > area[steady.REGION_B] > 0
    assert area[steady.REGION_A] > area[steady.REGION_C] > 0


def test_fig8_region_A_has_both_signs_of_omega20(fig8):
    ds, _ = fig8
    w20 = ds["omega20"].values[ds["region"].values == steady.REGION_A]
    assert (w20 > 0).any() and (w20 < 0).any()


def test_fig8_regions_sit_where_the_paper_says(fig8):
    """A inside-above (0, pi/2), B inside-below (-pi/2, 0), C outside-above (pi/2, pi)."""
    ds, _ = fig8
    beta = ds["beta0"].values[:, None] + 0 * ds["omega30"].values
    region = ds["region"].values
    for code, (lo, hi) in {steady.REGION_A: (0, np.pi / 2), steady.REGION_B: (-np.pi / 2, 0),
                           steady.REGION_C: (np.pi / 2, np.pi)}.items():
        b = beta[region == code]
        assert b.min() > lo and b.max() < hi


def test_fig8_only_region_A_at_3_m_per_s():
    ds, _ = _run("fig8", "v_throw=3", "n_beta0=241", "n_omega30=160")
    area = _areas(ds["region"].values)
    assert area[steady.REGION_A] > 0
    assert area[steady.REGION_B] == 0 and area[steady.REGION_C] == 0


def test_file_params_round_trip(quick_results):
    with xr.open_dataset(quick_results / "fig6.nc") as ds:
        assert params_of(ds) == solver.Params()


# Direct calls of solver.steady at a few grid points of each quick map.
CHECKS = {
    "fig3": {"omega20": lambda b, w, p, s: steady.omega20(b, w, p)},
    "fig5": {"h": lambda b, w, p, s: steady.stability(b, w, p),
             "stable": lambda b, w, p, s: steady.stability(b, w, p) < 0},
    "fig6": {"required_friction": lambda b, w, p, s: steady.required_friction(b, w, p),
             "F2": lambda b, w, p, s: steady.contact_forces(b, w, p)[1],
             "rolls": lambda b, w, p, s: steady.rolls_without_slipping(b, w, p, s["mu"])},
    "fig7": {"throw_speed": lambda b, w, p, s: steady.throw_speed(b, w, p),
             "within": lambda b, w, p, s: steady.throw_speed(b, w, p) <= s["v_throw"]},
    "fig8": {"region": lambda b, w, p, s: steady.realisable_region(b, w, p, s["v_throw"], s["mu"]),
             "omega20": lambda b, w, p, s: steady.omega20(b, w, p)},
}


@pytest.mark.parametrize("name", sorted(CHECKS))
def test_map_values_match_direct_solver_calls(quick_results, name):
    rng = np.random.default_rng(7)
    with xr.open_dataset(quick_results / f"{name}.nc") as ds:
        p = params_of(ds)
        settings = {k[len("setting_"):]: v for k, v in ds.attrs.items() if k.startswith("setting_")}
        settings.setdefault("mu", p.mu)
        i = rng.integers(0, ds.sizes["beta0"], 12)
        k = rng.integers(0, ds.sizes["omega30"], 12)
        b, w = ds["beta0"].values[i], ds["omega30"].values[k]
        for var, direct in CHECKS[name].items():
            stored = ds[var].values[i, k]
            expected = np.asarray(direct(b, w, p, settings))
            np.testing.assert_allclose(stored.astype(float), expected.astype(float), rtol=1e-12, err_msg=var)


def test_quick_grids_avoid_the_singular_lines():
    """Even omega30 counts and n_beta0 not divisible by 4 keep (48) finite everywhere."""
    for quick in (True, False):
        axes = make_plan(registry.get("fig3"), quick).grid
        b, w = axes[0].values, axes[1].values
        assert np.abs(np.cos(b)).min() > 1e-6 and np.abs(w).min() > 1e-6
        assert b[0] == -np.pi and b[-1] < np.pi
