"""Dimension names of every study: labelled categories, and never a keyword of xarray's sel/isel.

``ds.sel(method=1)`` on a dimension called ``method`` silently returns the whole dataset (the
keyword wins), so no study may name a dimension after a parameter of ``Dataset.sel`` or
``Dataset.isel``; categorical dimensions (scene, integrator) carry string labels.
"""

from __future__ import annotations

import inspect

import numpy as np
import pytest
import xarray as xr

from rimroll.peer_models import heyoka_rolling
from rimroll.study import registry
from rimroll.study.plan import make_plan
from rimroll.study.registry import RESERVED_DIM_NAMES, SWEEP_KEYS, Axis


def _keywords() -> set[str]:
    return {name for method in (xr.Dataset.sel, xr.Dataset.isel)
            for name in inspect.signature(method).parameters if name != "self"}


def test_reserved_names_cover_the_keywords_of_sel_and_isel():
    assert _keywords() <= RESERVED_DIM_NAMES, _keywords() - RESERVED_DIM_NAMES


@pytest.mark.parametrize("name", registry.names())
def test_no_dimension_or_coordinate_of_a_study_is_a_sel_keyword(name):
    plan = make_plan(registry.get(name), quick=True)
    names = {a.name for a in plan.axes} | {aux for a in plan.axes for aux in a.aux}
    names |= set(plan.study.sweepable)  # a sweep of any of them becomes a dimension
    assert not names & _keywords(), names & _keywords()


def test_sweepable_keys_are_not_sel_keywords():
    assert not set(SWEEP_KEYS) & _keywords()


def test_an_axis_named_like_a_keyword_is_refused():
    with pytest.raises(ValueError, match="'method' is a keyword of xarray"):
        Axis("method", np.arange(3), "1", "the integration method")


def test_categorical_axes_are_labelled_and_selectable():
    labels = Axis("scene", np.array(["rolling_only", "slipping"]), "", "scene",
                  aux={"mu": (np.array([np.inf, 1.0]), "1", "friction")})
    assert labels.categorical and labels.values.dtype.kind == "U"
    ds = xr.Dataset({"x": ("scene", [1.0, 2.0])}, coords={"scene": labels.values, "mu": ("scene", [np.inf, 1.0])})
    assert float(ds.sel(scene="slipping")["x"]) == 2.0
    for bad, match in ((["a b", "c"], "identifiers"), (["a", "a"], "distinct")):
        with pytest.raises(ValueError, match=match):
            Axis("scene", np.array(bad), "", "scene")


@pytest.mark.parametrize("name, dim, labels", [
    ("fig11", "scene", ["rolling_only", "slipping", "drilling", "rolling_resistance"]),
    ("work-precision", "scene", ["rolling_only", "slipping", "drilling", "rolling_resistance"]),
    ("work-precision", "integrator", ["rimroll_dp5", "rimroll_dop853", "scipy_rk45", "scipy_dop853", "scipy_lsoda"]
     + (["heyoka_taylor"] if heyoka_rolling.available() else []) + ["rimroll_reduced"]),  # heyoka: rimroll[bench]
])
def test_categorical_dimensions_have_the_agreed_labels(name, dim, labels):
    axes = {a.name: a for a in make_plan(registry.get(name), quick=True).axes}
    assert list(axes[dim].values) == labels
    if dim == "scene":  # the numbers of each scene stay as coordinates along it
        mu, k_r, k_d = (axes["scene"].aux[k][0] for k in ("mu", "k_r", "k_d"))
        assert np.isinf(mu[0]) and (mu[1:] == 1.0).all()
        assert k_d[2] > 0 and k_r[2] == 0 and k_r[3] > 0 and k_d[3] == 0
