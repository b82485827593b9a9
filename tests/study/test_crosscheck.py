"""The cross-check (study.crosscheck, ``study crosscheck``): the exact reduced solver against the
engine's stored reference slices, on the cells of conservative rolling-only scenes."""

from __future__ import annotations

import numpy as np
import pytest

from rimroll.solver.engine import outcomes
from rimroll.study import crosscheck, io, reference
from rimroll.study.cli import main


def test_fig11_rolling_only_slice_agrees_with_the_engine_and_the_other_scenes_are_named():
    check = crosscheck.check_study("fig11")
    (scene,) = check.scenes
    assert scene.scene == "rolling_only" and scene.cells == 36 * 24
    assert scene.differ == scene.near_boundary  # every difference (if any) next to another outcome
    assert scene.dt_median <= 1e-11 and scene.dt_max <= 1e-9  # DOP853 at rtol 1e-12: ~6.7e-14 / 7.5e-12 s seen
    assert check.ok and set(check.skipped) == {"slipping", "drilling", "rolling_resistance"}
    line = crosscheck.summary(check)
    assert "864 cells" in line and "not checked: slipping (mu=1.0)" in line and "\n" not in line


def test_a_wrong_outcome_away_from_boundaries_fails():
    with io.open_result(reference.reference_path("fig11")) as ds:
        ds = ds.load()
    out = ds["outcome"].isel(scene=0).values
    uniform = out == outcomes.FALL_OUT  # and so are its four neighbours and (i + 1, j)'s
    for axis, step in ((0, 1), (0, -1), (1, 1), (1, -1), (0, 2)):
        uniform &= crosscheck._neighbours(out, axis, step) == outcomes.FALL_OUT
    i, j = np.argwhere(uniform)[len(np.argwhere(uniform)) // 2]
    ds["outcome"][0, i, j] = outcomes.FALL_IN
    ds["t_end"][0, i + 1, j] += 1e-6  # and one t_end off by much more than the engine's tolerance
    check = crosscheck.check_dataset(ds, "fig11")
    scene = check.scenes[0]
    assert not check.ok and scene.differ == 1 and scene.near_boundary == 0
    assert scene.dt_max >= 1e-6 * (1 - 1e-6)
    assert "FAILED" in crosscheck.summary(check)


def test_a_difference_on_a_boundary_of_its_two_outcomes_is_near_it_a_lone_one_is_not():
    ref = np.array([[0, 0, 1, 1], [0, 0, 1, 1], [0, 0, 0, 0]])
    mine = ref.copy()
    mine[0, 1] = 1  # on the 0 | 1 boundary: neighbours (0, 0) = 0 and (0, 2) = 1 in both maps
    mine[2, 1] = 1  # a 1 amid 0s
    assert crosscheck.near_boundary(ref, mine).tolist() == [[False, True, False, False], [False] * 4, [False] * 4]


def test_a_study_without_states_is_named_with_why_and_an_unknown_one_is_one_line(capsys):
    check = crosscheck.check_study("fig3")
    assert not check.checked and check.ok and "no outcome" in check.why_not
    assert main(["crosscheck", "fig3"]) == 1  # nothing checked
    assert "nothing checked" in capsys.readouterr().out
    assert main(["crosscheck", "no-such-study"]) == 2
    assert capsys.readouterr().err.count("\n") == 1


@pytest.mark.slow
@pytest.mark.parametrize("grid", reference.GRIDS)
def test_every_slice_the_reduced_solver_can_solve_agrees(grid, capsys):
    assert main(["crosscheck", "--grid", grid]) == 0, capsys.readouterr().out
    out = capsys.readouterr().out
    for name in ("fig11", "fig12", "fig13", "continuation", "predictability"):
        assert f"{name} ({grid} slice): " in out and f"{name} ({grid} slice): not checked" not in out
