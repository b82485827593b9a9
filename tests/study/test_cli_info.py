"""Inspecting studies before running them: study list order, study info NAME, run NAME --help, --version."""

from __future__ import annotations

import re

import pytest

from rimroll.study import registry
from rimroll.study.cli import main, natural_order


def test_list_is_in_natural_order(capsys):
    assert main(["list"]) == 0
    names = [line.split()[0] for line in capsys.readouterr().out.splitlines()]
    assert sorted(names) == sorted(registry.names())
    figs = [n for n in names if re.fullmatch(r"fig\d+", n)]
    assert names[: len(figs)] == figs  # the paper's figures first
    assert [int(n[3:]) for n in figs] == sorted(int(n[3:]) for n in figs)  # fig9 before fig11
    rest = names[len(figs):]
    assert rest == sorted(rest)


def test_list_gives_each_studys_own_title(capsys):
    assert main(["list"]) == 0
    rows = [line.split(None, 1) for line in capsys.readouterr().out.splitlines()]
    assert {name: title for name, title in rows} == {name: registry.get(name).title for name in registry.names()}


def test_the_catalogue_holds_what_the_studies_declare():
    """study/catalogue.json (what list, info NAME and run NAME --help say without importing the studies) is
    the card each study makes of itself: title, summary, variables, settings, grids, run-time model."""
    from rimroll.study import catalogue

    stored, built = catalogue.stored(), catalogue.build()
    stale = sorted(name for name in {*stored, *built} if stored.get(name) != built.get(name))
    assert not stale, f"study/catalogue.json differs from the studies {stale}: run python docs/gen_studies.py"
    assert set(built) == set(registry.names())  # every study of rimroll's own has its card


def test_info_from_the_catalogue_is_the_studys_own_description(capsys):
    """study info NAME from the catalogue's card prints what the study's module describes, line for line."""
    from rimroll.study import catalogue
    from rimroll.study.describe import describe, render

    for name in ("fig8", "fig11", "outcome-cube", "work-precision"):
        assert catalogue.card(name) is not None, name
        assert main(["info", name]) == 0
        assert capsys.readouterr().out.splitlines() == describe(name) == render(catalogue.card(name)), name


def test_a_study_without_a_card_is_described_from_its_module(capsys, monkeypatch):
    """A missing catalogue, or a card whose entry point now names another module (a study moved since the
    file was made), is not used: list, info and run --help then read the study itself."""
    from rimroll.study import catalogue

    assert main(["info", "fig11"]) == 0
    assert main(["list"]) == 0
    assert main(["run", "fig11", "--help"]) == 0
    expected = capsys.readouterr().out
    moved = {name: {**entry, "module": "elsewhere"} for name, entry in catalogue.stored().items()}
    for cards in ({}, moved):
        monkeypatch.setattr(catalogue, "stored", lambda cards=cards: cards)
        assert catalogue.card("fig11") is None and catalogue.titles() is None
        assert main(["info", "fig11"]) == 0
        assert main(["list"]) == 0
        assert main(["run", "fig11", "--help"]) == 0
        assert capsys.readouterr().out == expected


def test_natural_order_compares_numbers_as_numbers():
    assert natural_order(["fig11", "b", "fig9", "a", "fig10"]) == ["fig9", "fig10", "fig11", "a", "b"]


def test_info_of_a_study_name(capsys):
    assert main(["info", "fig8"]) == 0
    out = capsys.readouterr().out
    assert out.startswith("fig8: " + registry.get("fig8").title)
    assert re.search(r"v_throw\s+10\s+\[m s-1\]", out)  # setting, default, units
    assert re.search(r"n_beta0\s+721\s+\(--quick 121\)", out)
    assert "grid: beta0 721 x omega30 560 = 403760 points" in out
    assert "grid with --quick: beta0 121 x omega30 80 = 9680 points" in out
    assert "run time" in out and "sweepable" in out


def test_info_of_a_cube_names_its_sweepable_settings(capsys):
    assert main(["info", "outcome-cube"]) == 0
    out = capsys.readouterr().out
    assert re.search(r"k_r\s+0,0\.01,0\.02\s+\(--quick 0,0\.02\).*\(sweepable\)", out)
    assert "compiles its simulation kernels" in out


def test_info_of_neither_file_nor_study_is_a_user_error(capsys):
    assert main(["info", "no-such-thing"]) == 2
    err = capsys.readouterr().err
    assert err.startswith("study: error:") and "fig8" in err and len(err.splitlines()) == 1


def test_run_help_lists_the_studys_settings(capsys):
    assert main(["run", "fig11", "--help"]) == 0
    out = capsys.readouterr().out
    assert "--quick" in out and "--set" in out  # the run options
    assert re.search(r"mu_slip\s+1\s+\[1\]", out) and re.search(r"t_max_dissipative\s+60\s+\[s\]", out)


def test_version(capsys):
    with pytest.raises(SystemExit) as exc:
        main(["--version"])
    assert exc.value.code == 0
    from rimroll.study.dataset import rimroll_version

    assert capsys.readouterr().out.startswith(f"study (rimroll) {rimroll_version()}")


def test_info_does_not_offer_parameters_that_run_refuses(capsys, tmp_path):
    """fig11 ignores mu, k_r, k_d (its scenes set them; ``Study.ignores``): study info lists them as
    not used instead of as settings, and --set of one is indeed refused."""
    assert main(["info", "fig11"]) == 0
    lines = capsys.readouterr().out.splitlines()
    assert not any(re.match(r"\s+(mu|k_r|k_d)\s", line) for line in lines)
    assert any("not used" in line and "mu, k_r, k_d" in line for line in lines)
    assert any(re.match(r"\s+mu_slip\s+1\s", line) for line in lines)
    assert main(["run", "fig11", "--quick", "--set", "mu=2", "--out", str(tmp_path)]) == 2
    assert "mu" in capsys.readouterr().err


def test_info_of_a_study_names_what_it_derives_and_no_issue_numbers(capsys):
    assert main(["info", "fig11"]) == 0
    out = capsys.readouterr().out
    derived = [line for line in out.splitlines() if line.startswith("derived from the whole grid")]
    assert derived and "boundary_type [1]" in derived[0] and "former_periodic [1]" in derived[0]
    for name in registry.names():  # a description cites the paper or the docs, never the tracker
        assert main(["info", name]) == 0
        assert not re.search(r"\(issue \d+\)", capsys.readouterr().out), name


def test_info_of_an_outcome_file_gives_each_scenes_parameters(tmp_path, capsys):
    assert main(["run", "fig12", "--quick", "--set", "n_beta=4", "--set", "n_omega1=4", "--out", str(tmp_path),
                 "--no-progress"]) == 0
    capsys.readouterr()
    assert main(["info", str(tmp_path / "fig12.nc")]) == 0
    out = capsys.readouterr().out
    assert re.search(r"^  mu \[1\] .*: inf, 1, 1, 1 \(per scene\)", out, re.M)
    assert re.search(r"^  k_r \[s-1\] .*: 0, 0, 0, 0\.02 \(per scene\)", out, re.M)
    (params,) = [line for line in out.splitlines() if line.startswith("parameters:")]
    assert not re.search(r"\b(mu|k_r|k_d)=", params)  # no one global value of what each scene sets


_HEAVY = ("numba", "dask", "xarray", "distributed", "matplotlib", "rimroll.solver.engine.kernels", "rimroll.workflows")
_LOADED = ("import sys\n"
           "from rimroll.study.cli import main\n"
           "try:\n"
           "    status = main(sys.argv[1:])\n"
           "except SystemExit as exc:\n"
           "    status = exc.code\n"
           f"print(status, *sorted(m for m in {_HEAVY!r} if m in sys.modules), file=sys.stderr)\n")


@pytest.mark.parametrize("argv, status", [
    (["--help"], 0),
    (["run", "--help"], 0),
    (["list"], 0),  # the studies' titles, settings and grids: from the catalogue (study/catalogue.json)
    (["info", "fig8"], 0),
    (["info", "fig11"], 0),
    (["run", "fig11", "--help"], 0),
    (["run", "fig1l"], 2),  # a misspelt study name
    (["info", "fig1l"], 2),
    (["plot", "fig1l"], 2),
    (["run", "fig11", "--workers", "0"], 2),
    (["trace", "--state", "-1.57,0,0,0"], 2),
])
def test_help_and_refusals_answer_without_the_numerical_libraries(argv, status):
    """`study --help`, `study list`, `study info NAME`, `study run NAME --help` and the refusal of a misspelt
    name import neither numba, dask, xarray nor the studies' modules (a fresh process: what the command itself
    imports): they answer in a fraction of a second."""
    import subprocess
    import sys

    out = subprocess.run([sys.executable, "-c", _LOADED, *argv], capture_output=True, text=True, timeout=120)
    last = out.stderr.strip().splitlines()[-1].split()
    assert last == [str(status)], out.stderr[-2000:]
