"""Each concept declared once: the setting table, the fields of a Study record, one KEY=VALUE parser.

- every setting of every registered study has one entry in ``study.setting_table`` (units, doc,
  allowed values), the physical parameters' taken from ``solver.physics.params.QUANTITIES``, which
  ``Params`` validates with; the checks before a run, ``study info`` and the docs read that table;
- a study's run-time estimate and its reference slices are fields of its ``Study`` record;
- ``study.cli_text`` splits ``--set``, ``--select`` and ``--at`` words with one rule.
"""

from __future__ import annotations

import ast
import dataclasses
import math
import re

import numpy as np
import pytest
import xarray as xr

from rimroll import solver
from rimroll.solver.physics import params as physical
from rimroll.study import checks, cli_text, describe, reference, registry, setting_table
from rimroll.study.cli import _selection, main
from rimroll.study.registry import PHYSICAL_KEYS, Axis, ReferenceSpec, Study, UserError, Var
from rimroll.study.setting_table import TABLE, lookup
from tests.helpers.paths import ROOT

PROBES = (-1e13, -1.0, -1, 0, 0.0, 1e-15, 0.5, 1, 2, 3.5, 1e5, 100001, 1e13, math.inf, -math.inf, math.nan)


def _studies():
    """rimroll's own studies (not the test-only ones other tests register, such as fanout-probe)."""
    studies = [registry.get(name) for name in registry.names()]
    return [s for s in studies if s.compute.__module__.startswith("rimroll.workflows.")]


# ================================================================ the setting table
def test_every_setting_of_every_study_has_one_entry_with_units_doc_and_allowed_values():
    for study in _studies():
        names = {*study.settings, *study.quick, *study.sweepable, *PHYSICAL_KEYS}
        for name in names:
            assert name in TABLE, f"{study.name}: setting {name!r} has no entry in study/setting_table.py"
            entry = TABLE[name]
            assert isinstance(entry.units, str) and entry.doc.strip(), name
            default = study.settings.get(name, study.quick.get(name))
            if isinstance(default, (int, float)) and not isinstance(default, bool) or name in PHYSICAL_KEYS:
                assert entry.range is not None, f"{name}: a number needs its range in the table"
            elif isinstance(default, str) and entry.choices is None:
                assert entry.range is None, name  # a free label the study checks itself (subset)
        for name in study.sweepable:
            assert TABLE[name].sweep, (study.name, name)


def test_a_setting_declared_twice_is_refused():
    entry = TABLE["rtol"]
    with pytest.raises(ValueError, match="declared twice"):
        setting_table._table([entry, dataclasses.replace(entry, doc="another doc")])
    # the study table restates none of the physical parameters: their entries are the params table's
    for name, q in physical.QUANTITIES.items():
        assert TABLE[name].physical and TABLE[name].range is q.range and TABLE[name].units == q.units
    assert {n for n, s in TABLE.items() if s.physical} == set(physical.QUANTITIES)
    assert physical.FIELDS == PHYSICAL_KEYS == tuple(q for q in physical.QUANTITIES if q != "rho_over_R")
    assert set(registry.SWEEP_KEYS) == {n for n, s in TABLE.items() if s.sweep}


def test_the_checks_and_params_follow_the_table_and_nothing_else():
    """check_setting refuses exactly what the table's entry refuses (no rule of its own), and
    Params refuses exactly what the params table refuses, with the same one-line message."""
    undeclared = [(name, lookup(name)) for name in ("n_x", "t_max_x", "delay")]  # wildcards, the common rule
    for name, entry in [*TABLE.items(), *undeclared]:
        values = [*PROBES, *(entry.labels() if entry.choices is not None else ()), "rk4"]
        for value in values:
            problem = entry.problem(value)
            try:
                checks.check_setting("s", name, value)
                refused = None
            except UserError as exc:
                refused = str(exc)
            assert (refused is None) == (problem is None), (name, value, refused, problem)
            if refused:
                assert "\n" not in refused and f"{name}={value!r}" in refused and "allowed" in refused
    for name in PHYSICAL_KEYS:
        for value in PROBES:
            problem = TABLE[name].problem(value)
            try:
                solver.Params(**{name: value}, **({"R": 1e6} if name in ("r", "a") else {}))
                message = None
            except ValueError as exc:
                message = str(exc)
            if problem is None:
                assert message is None or "geometry" in message, (name, value, message)
            else:
                assert message == f"parameter {name}={float(value)!r} is out of range: {problem}", (name, value)


def test_every_studys_defaults_and_quick_values_pass_the_checks():
    for study in _studies():
        for values in (study.settings, study.quick):
            checks.check_settings(study.name, {k: tuple(v) if isinstance(v, list) else v for k, v in values.items()})


def test_out_of_range_messages_name_setting_value_and_what_is_allowed(tmp_path, capsys):
    cases = [(["fig11", "--quick", "--set", "rtol=0"], "setting rtol=0.0 is out of range for study 'fig11': "
                                                       "allowed 1e-14 <= rtol <= 0.01"),
             (["fig11", "--quick", "--set", "method=rk4"], "allowed methods are auto, dop853, dp5"),
             (["fig8", "--set", "j=-1"], "parameter j=-1.0 is out of range: allowed a positive number below 1e12"),
             (["predictability", "--quick", "--set", "n_fine=-1"], "allowed an integer 0 <= n_fine <= 100000"),
             # a swept value and a new grid value are checked by the same table
             (["realisable-cube", "--quick", "--set", "v_throw=1,-2"], "v_throw=-2.0 is out of range"),
             (["fig11", "--quick", "--set", "beta=0:1e300:3"], "grid value beta=5e+299 is out of range"),
             (["fig9", "--quick", "--set", "j=0,0.5"], "parameter j=0.0 is out of range"),
             (["make-probability", "--quick", "--set", "confidence=1"], "allowed 0 < confidence < 1")]
    for argv, expect in cases:
        assert main(["run", *argv, "--out", str(tmp_path / "o"), "--no-progress"]) == 2
        err = capsys.readouterr().err.strip()
        assert err.startswith("study: error:") and "\n" not in err and expect in err, (argv, err)
    assert not (tmp_path / "o").exists()


def test_study_info_and_run_help_show_the_tables_units_doc_and_range(monkeypatch, capsys):
    assert main(["info", "fig11"]) == 0
    out = capsys.readouterr().out
    entry = TABLE["rtol"]
    assert re.search(rf"rtol\s+1e-08\s+\[1\]\s+{re.escape(entry.doc)} \(1e-14 <= rtol <= 0\.01\)", out)
    assert re.search(r"method\s+auto\s+.*\(methods auto, dop853, dp5\)", out)
    # what the table says is what info says: change an entry, and the line changes (of the study described
    # from its module; the catalogue's cards are made that way, tests/study/test_cli_info.py)
    from rimroll.study import catalogue

    monkeypatch.setattr(catalogue, "stored", dict)
    monkeypatch.setitem(TABLE, "t_max_dissipative", dataclasses.replace(TABLE["t_max_dissipative"], units="min",
                                                                        doc="a doc from the table"))
    assert main(["run", "fig11", "--help"]) == 0
    assert re.search(r"t_max_dissipative\s+60\s+\[min\]\s+a doc from the table", capsys.readouterr().out)


def test_swept_axes_take_units_and_long_name_from_the_table(tmp_path):
    from rimroll.study.plan import make_plan

    plan = make_plan(registry.get("make-probability"), True, {"sigma": [0.5, 1], "mu": [0.5, 1]})
    axes = {a.name: a for a in plan.outer}
    for name in ("sigma", "mu"):
        assert (axes[name].units, axes[name].long_name) == (TABLE[name].units, TABLE[name].axis_long_name)
    assert axes["mu"].long_name == physical.QUANTITIES["mu"].long_name


def test_the_docs_list_every_setting_with_the_tables_units_and_range():
    """The site's settings page (reference/settings.md, generated by docs/site_hooks.py) has every setting
    with the table's allowed values."""
    import sys

    sys.path.insert(0, str(ROOT / "docs"))
    try:
        import site_hooks
    finally:
        sys.path.remove(str(ROOT / "docs"))
    rows = dict(re.findall(r"^\| `(\w+)` \| [^|]* \| .*? \| (.*?) \|$", site_hooks.settings_page(), re.M))
    for study in _studies():
        for name in study.settings:
            entry = TABLE[name]
            allowed = entry.allowed() if entry.choices is not None or entry.range is not None else None
            assert name in rows, f"{name}: missing from the settings page"
            if allowed:
                assert rows[name] == allowed.replace("|", "\\|"), name


# ================================================================ fields of the Study record
def _toy(**fields) -> Study:
    def axes(s):
        return [Axis("x", np.linspace(0.0, 1.0, s["n_x"]), "1", "toy coordinate")]

    return Study(name="toy-record", title="a toy", settings={"n_x": 9, "t_max": 10.0}, quick={"n_x": 5, "t_max": 2.0},
                 axes=axes, variables=[Var("y", "1", "twice x")], compute=lambda c, p, s: {"y": 2.0 * c[0]},
                 ignores={k: "a toy" for k in ("k_r", "k_d")}, **fields)


def test_the_estimate_of_study_info_comes_from_the_study_record(monkeypatch, capsys):
    toy = _toy(cost=0.5, cost_scale="t_max", compiles=True)
    monkeypatch.setitem(registry._REGISTRY, toy.name, toy)
    assert describe.estimate(toy, 4, 1, quick=True) == \
        "about 2 s (the first run of an install also compiles its simulation kernels, once: announced, with the time " \
        "their last compile took on this machine)"
    assert describe.estimate(toy, 4, 1).startswith("about 10 s")  # t_max 10 s at the default, 2 s measured
    assert describe.estimate(_toy(cost=0.5), 4, 2) == "about 1 s"
    assert describe.estimate(_toy(), 4, 2) == "no estimate for this study"
    assert main(["info", toy.name]) == 0
    assert "grid with --quick: x 5 = 5 points in 1 chunks; run time on" in capsys.readouterr().out
    with pytest.raises(ValueError, match="cost_scale"):
        _toy(cost=1.0, cost_scale="no_such_setting")
    with pytest.raises(ValueError, match="cost"):
        _toy(cost=-1.0)


def test_reference_slices_come_from_the_study_record(monkeypatch, tmp_path, capsys):
    assert reference.specs() == {s.name: s.reference for s in _studies() if s.reference is not None}
    assert list(reference.specs()) == registry.natural_order(reference.specs())
    toy = _toy(reference=ReferenceSpec({"x": 3}, method="twice x"))
    monkeypatch.setitem(registry._REGISTRY, toy.name, toy)
    assert reference.sub_grid(toy.name) == {"x": (0.0, 0.5, 1.0)}
    out = tmp_path / "slices"
    argv = ["reference", "--build", "--only", toy.name, "--out", str(out), "--no-progress", "--workers", "1"]
    assert main(argv) == 0
    capsys.readouterr()
    with xr.open_dataset(out / f"{toy.name}.nc") as ds, xr.open_dataset(out / "quick" / f"{toy.name}.nc") as quick:
        np.testing.assert_array_equal(ds["x"].values, [0.0, 0.5, 1.0])
        assert ds.attrs["reference_method"] == "twice x"
        assert "x: 3 of the default values" in ds.attrs["reference_settings"]
        assert quick.sizes["x"] == 5
    bare = dataclasses.replace(_toy(), name="toy-without-slices")  # a study of another package may have none
    monkeypatch.setitem(registry._REGISTRY, bare.name, bare)
    assert main(["reference", "--build", "--only", "fig3", "--only", bare.name, "--out", str(out)]) == 2
    assert f"no reference slice for {bare.name}" in capsys.readouterr().err


# ================================================================ one KEY=VALUE parser
def test_one_parser_serves_both_meanings_of_a_comma():
    assert cli_text.split("mu=0.5,1,2", "--set") == [("mu", "0.5,1,2")]  # one key, a list
    assert cli_text.split("omega1=0.5,beta=1.2", "--at") == [("omega1", "0.5"), ("beta", "1.2")]  # two pairs
    assert cli_text.split("mu=0.5,1, v_throw = 2", "--set") == [("mu", "0.5,1"), ("v_throw", "2")]
    assert cli_text.split("mu=0.5:2:5", "--set") == [("mu", "0.5:2:5")]
    assert cli_text.split("mu=0.5,,2", "--set") == [("mu", "0.5,,2")]  # an empty item: the caller says so
    assert cli_text.parse(["j=0.5", "mu=1,k_r=0"], "--select") == [("j", "0.5"), ("mu", "1"), ("k_r", "0")]
    for word in ("mu", "=1", "mu=", "0.5,mu=1", ""):
        with pytest.raises(UserError) as exc:
            cli_text.split(word, "--set", "KEY=VALUE", "--set mu=0.5")
        assert str(exc.value) == f"malformed --set {word!r}: expected KEY=VALUE, e.g. --set mu=0.5"


def test_every_key_value_option_uses_the_one_parser():
    ds = xr.Dataset(coords={"j": [0.5, 1.0], "mu": [1.0, 2.0]}, attrs={"swept": "j mu"})
    assert _selection(["j=0.5,mu=1"], ds) == {"j": 0.5, "mu": 1.0}  # --select j=0.5,mu=1
    assert _selection(["j=0.5", "mu=2"], ds) == {"j": 0.5, "mu": 2.0}
    with pytest.raises(UserError, match="malformed --select 'j'"):
        _selection(["j"], ds)
    from rimroll.study import rim_trace as trace

    assert trace.parse_sets(["mu=inf,j=0.5", "k_r=0.01"]) == {"mu": math.inf, "j": 0.5, "k_r": 0.01}
    at = trace._parse_at("omega1=0.5,beta=1.2,scene=slipping")
    assert at == {"omega1": "0.5", "beta": "1.2", "scene": "slipping"}
    for path in ("cli.py", "rim_trace.py", "shot_trace.py"):
        source = (ROOT / "study" / path).read_text()
        assert ".partition(\"=\")" not in source and "cli_text." in source, path
    for path in ("settings.py", "plan.py", "api.py"):  # past the command line's edge no setting is text
        tree = ast.parse((ROOT / "study" / path).read_text())
        imported = {f"{node.module}.{alias.name}" for node in ast.walk(tree) if isinstance(node, ast.ImportFrom)
                    for alias in node.names}
        assert not any("cli_text" in name for name in imported), path


def test_functions_of_the_solver_and_the_study_layer_are_short_and_take_few_parameters():
    """docs/architecture.md: at most 120 lines and 12 parameters (what travels together is a record)."""
    paths = sorted((ROOT / "study").rglob("*.py")) + sorted((ROOT / "solver").rglob("*.py"))
    assert len(paths) > 40
    for path in paths:
        for node in ast.walk(ast.parse(path.read_text())):
            if isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef)):
                a = node.args
                count = len(a.posonlyargs) + len(a.args) + len(a.kwonlyargs) + bool(a.vararg) + bool(a.kwarg)
                assert node.end_lineno - node.lineno + 1 <= 120 and count <= 12, (str(path), node.name)
