"""The exact-boundaries study (workflows/boundary_polylines.py): its crossings lie between cells of
different outcome and separate the two outcomes at adjacent doubles, its polylines pass through
them, and the adaptive map's boundaries lie within half a cell of them."""

from __future__ import annotations

import numpy as np
import pytest

from rimroll import solver
from rimroll.solver.analysis import exact_boundaries as eb
from rimroll.study import registry
from rimroll.study.outcome_sections import FIGURES
from rimroll.study.plan import make_plan
from rimroll.workflows import boundary_polylines as bp

N_BETA, N_OMEGA1 = 10, 14  # a coarse grid of fig11's section: seconds, with boundaries of every kind near


@pytest.fixture(scope="module")
def fig11_section():
    s = make_plan(registry.get(bp.NAME), quick=True).settings
    s = {**s, "n_beta": N_BETA, "n_omega1": N_OMEGA1}
    _, beta, omega1 = (a.values for a in bp._axes(s))
    p = solver.Params()
    return s, p, beta, omega1, bp.section(p, s, FIGURES[0][1], beta, omega1)


def test_the_sections_are_those_of_figs_11_to_13():
    axes = make_plan(registry.get(bp.NAME)).axes
    omega2 = next(a for a in axes if a.name == "omega2").values
    assert omega2.tolist() == [registry.get(name).settings["omega2"] for name, _, _ in FIGURES]
    fig11 = make_plan(registry.get("fig11")).axes
    for name in ("beta", "omega1"):  # the default grid is fig11's
        np.testing.assert_array_equal(next(a for a in axes if a.name == name).values,
                                      next(a for a in fig11 if a.name == name).values)


def _crossings(out, beta, omega1):
    for axis, name, along in ((0, "beta", beta), (1, "omega1", omega1)):
        at = out[f"crossing_{name}"]
        i, j = np.nonzero(np.isfinite(at))
        yield axis, along, i, j, at[i, j], out[f"crossing_{name}_kind"][i, j]


def test_every_crossing_lies_between_cells_of_different_outcome_at_adjacent_doubles(fig11_section):
    s, p, beta, omega1, out = fig11_section
    codes = out["outcome"]
    run, _ = bp.runner(p, s, FIGURES[0][1])
    n = 0
    for axis, along, i, j, at, kind in _crossings(out, beta, omega1):
        i2, j2 = i + (axis == 0), j + (axis == 1)
        a, b = (i, i2) if axis == 0 else (j, j2)
        assert (codes[i, j] != codes[i2, j2]).all()
        assert ((along[a] < at) & (at < along[b])).all()
        assert np.isin(kind, (0, 1, 2)).all()
        fixed = np.where(axis == 0, omega1[j], beta[i])
        sides = []
        for x in (np.nextafter(at, -np.inf), at, np.nextafter(at, np.inf)):
            bb, ww = (x, fixed) if axis == 0 else (fixed, x)
            sides.append(np.asarray(run(bb, ww)["outcome"]))
        # the crossing is one of two adjacent doubles: the first cell's outcome on its side, the other's beyond
        lo = (sides[0] == codes[i, j]) | (sides[1] == codes[i, j])
        hi = (sides[1] == codes[i2, j2]) | (sides[2] == codes[i2, j2])
        assert lo.all() and hi.mean() >= 0.9  # a third outcome inside a link puts a few ends elsewhere
        n += at.size
    # every link of the grid was located, and none elsewhere
    assert n == eb.links(codes)[0].size > 10


def test_the_adaptive_maps_boundaries_lie_within_half_a_cell(fig11_section):
    _, _, beta, omega1, out = fig11_section
    for name, along in (("beta", beta), ("omega1", omega1)):
        d = out[f"distance_{name}"]
        d = d[np.isfinite(out[f"crossing_{name}"])]
        assert d.size and np.isfinite(d).all()
        assert d.max() <= 0.5 * np.diff(along).max() * (1 + 1e-12)


def test_the_polylines_pass_through_the_crossings(fig11_section):
    _, _, beta, omega1, out = fig11_section
    x = eb.Crossings(*[np.concatenate(v) for v in zip(*[
        (i, j, np.full(i.size, axis, np.int8), at, at, out["outcome"][i, j],
         out["outcome"][i + (axis == 0), j + (axis == 1)], np.zeros(i.size), np.zeros(i.size), kind,
         np.ones(i.size, bool)) for axis, _, i, j, at, kind in _crossings(out, beta, omega1)])])
    curves, r, c = eb.exact_curves(x, beta, omega1, out["outcome"])
    points = set(zip(r.tolist(), c.tolist()))
    on_beta = x.axis == 0
    crossing_points = set(zip(np.where(on_beta, x.at, beta[x.i]).tolist(),
                              np.where(on_beta, omega1[x.j], x.at).tolist()))
    assert crossing_points <= points


@pytest.mark.parametrize("setting,allowed", [("adaptive_coarse=3", "power of 2"), ("f2_rel=2", "0 < f2_rel < 1"),
                                             ("mu=2", "does not use 'mu'")])
def test_bad_settings_are_one_line_errors(tmp_path, capsys, setting, allowed):
    from rimroll.study.cli import main

    assert main(["run", bp.NAME, "--quick", "--set", setting, "--out", str(tmp_path)]) == 2
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and allowed in err and "Traceback" not in err
    assert not list(tmp_path.iterdir())  # nothing computed, nothing written
