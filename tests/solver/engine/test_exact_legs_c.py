"""The exact rolling solver's legs compiled at install (``solver/engine/_exact_legs.c``) against the numba kernel.

Both implement the algorithm of ``solver.engine.reduced_rolling``; the compiled one is what ``simulate`` runs, the
numba kernel is what an install without a C compiler runs. On legs of the Fig. 11 rolling section (every start
the solver makes there: first legs, second legs from the start the other way, legs stopped at a given angle) they
must end at the same event, at the same angle and time to rounding.
"""

from __future__ import annotations

import numpy as np
import pytest

from rimroll import solver
from rimroll.solver.engine import reduced_compiled, reduced_legs, reduced_simulate, reduced_tables
from rimroll.solver.engine import reduced_rolling as rr

P = solver.Params(mu=np.inf)


def _section_jobs(n, seed=0):
    """Job rows of ``reduced_rolling`` for n random rolling states of the Fig. 11 section (omega2 = 35 1/s,
    omega3 = 10 1/s), in both directions, a quarter of them stopped halfway to a panel edge, and the level's
    table arguments."""
    rng = np.random.default_rng(seed)
    x0 = np.stack([rng.uniform(0.6, 2.0, n), rng.uniform(-6.0, 6.0, n), np.full(n, 35.0), np.full(n, 10.0)], -1)
    x0[: n // 10, 1] = 0.0  # turning-point starts
    table = reduced_simulate._table(P.rho / P.R, P.j)
    turn = reduced_legs.turning_starts(x0, P, table.width)
    level = reduced_legs.Level(table, P, *reduced_simulate._levels(x0, table, P, turn))
    d = np.where(rng.random(n) < 0.5, 1.0, -1.0)
    stop = np.where(rng.random(n) < 0.25, x0[:, 0] + d * rng.uniform(0.01, 1.0, n), d * np.inf)
    jobs = np.zeros((n, rr.N_J))
    jobs[:, rr.J_BETA], jobs[:, rr.J_DIR], jobs[:, rr.J_SING], jobs[:, rr.J_STOP] = x0[:, 0], d, turn, stop
    p1, p2 = level.p1, level.p2
    jobs[:, rr.J_C0], jobs[:, rr.J_P1], jobs[:, rr.J_P2] = level.c0, p1, p2
    jobs[:, rr.J_Q0], jobs[:, rr.J_Q1], jobs[:, rr.J_Q2] = p1 * p1, 2 * p1 * p2, p2 * p2
    return jobs, (table.values, table.nodes, table.spread, level.constants(), reduced_legs.RULE)


def test_the_install_built_the_compiled_legs():
    """``pip install`` compiles them (pyproject.toml, ext-modules) and their layout is this source's: the exact
    solver then compiles nothing at run time."""
    assert reduced_compiled.library() is not None, (
        "rimroll.solver.engine._exact_legs is missing or stale: reinstall rimroll with a C compiler present")


def test_the_compiled_legs_equal_the_numba_kernels():
    jobs, args = _section_jobs(3000)
    got_c, got_nb = np.zeros((len(jobs), rr.N_O)), np.zeros((len(jobs), rr.N_O))
    reduced_compiled.legs()(jobs, *args, got_c)
    reduced_legs._numba_legs(jobs, *args, got_nb)
    kinds = got_nb[:, rr.O_KIND]
    assert set(np.unique(kinds)) >= {rr.EV_TURN, rr.EV_FALL, rr.EV_STOP}  # every way a leg ends is compared
    assert np.array_equal(got_c[:, rr.O_KIND], kinds)
    assert np.array_equal(got_c[:, rr.O_OK], got_nb[:, rr.O_OK])
    assert np.all(got_nb[:, rr.O_OK] == 1.0)
    assert np.allclose(got_c[:, rr.O_BETA], got_nb[:, rr.O_BETA], rtol=0, atol=1e-14)
    t_nb = got_nb[:, rr.O_T]
    assert np.all(np.abs(got_c[:, rr.O_T] - t_nb) <= 1e-13 * np.maximum(t_nb, 1e-3))  # [s]: rounding of the sums
    assert np.allclose(got_c[:, rr.O_ALPHA], got_nb[:, rr.O_ALPHA], rtol=1e-12, atol=1e-15)
    assert np.allclose(got_c[:, rr.O_FMIN], got_nb[:, rr.O_FMIN], rtol=1e-12, atol=1e-12)  # F2/m [m/s^2]


def test_the_compiled_table_evaluation_equals_numpys():
    table = reduced_simulate._table(P.rho / P.R, P.j)
    beta = np.concatenate([np.linspace(-1.5, 4.7, 2001), [table.beta_lo, table.beta_lo + table.width]])
    rows = (reduced_tables.PHI11, reduced_tables.Q22, reduced_tables.SIN, reduced_tables.G22)
    got = reduced_compiled.evaluate_many(table, beta, rows)
    want = reduced_tables.evaluate_many(table, beta, rows)
    assert got.shape == want.shape == (4, beta.size)
    assert np.allclose(got, want, rtol=0, atol=1e-14 * np.abs(want).max())


def test_bad_arrays_and_rows_are_refused_with_one_line():
    jobs, args = _section_jobs(4)
    legs = reduced_compiled.legs()
    with pytest.raises(ValueError, match="jobs: need a C-contiguous float64 array"):
        legs(np.asfortranarray(jobs), *args, np.zeros((4, rr.N_O)))
    with pytest.raises(ValueError, match="out has 3 rows for 4 jobs"):
        legs(jobs, *args, np.zeros((3, rr.N_O)))
    with pytest.raises(ValueError, match="disagree on the number of panels"):
        legs(jobs, args[0][:-1], *args[1:], np.zeros((4, rr.N_O)))
    with pytest.raises(ValueError, match="functions: need table rows in 0..12"):
        reduced_compiled.evaluate_many(reduced_simulate._table(P.rho / P.R, P.j), [1.0], (13,))


def test_a_library_of_another_layout_is_not_used(monkeypatch):
    """A stale build (compiled for other table shapes or tolerances) is refused, and the numba kernel runs."""
    monkeypatch.setattr(reduced_compiled, "TOLERANCES", (rr.H_MIN, rr.QUAD_RTOL * 10, rr.NEAR))
    reduced_compiled.library.cache_clear()
    try:
        assert reduced_compiled.library() is None and reduced_compiled.legs() is None
        res = solver.simulate([[1.1, 1.17, 35.0, 10.0]], P, method="reduced", workers=1)
    finally:
        monkeypatch.undo()
        reduced_compiled.library.cache_clear()
    want = solver.simulate([[1.1, 1.17, 35.0, 10.0]], P, method="reduced", workers=1)
    assert reduced_compiled.library() is not None
    assert res["outcome"] == want["outcome"] and abs(res["t_end"] - want["t_end"]) < 1e-12
