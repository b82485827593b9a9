"""Layering: ``rimroll.solver`` is pure numpy (no xarray, dask, study); ``rimroll.study`` finds the
studies through the ``rimroll.studies`` entry-point group and never imports ``rimroll.workflows`` itself."""

from __future__ import annotations

import re
import subprocess
import sys

import pytest

from tests.helpers.paths import ROOT


def _loaded_after(statement: str) -> set[str]:
    """Top-level modules loaded by ``statement``, rimroll's subpackages named without the prefix."""
    code = (f"import sys\n{statement}\n"
            "print(' '.join(sorted({m.removeprefix('rimroll.').split('.')[0] for m in sys.modules})))")
    out = subprocess.run([sys.executable, "-c", code], cwd=ROOT, capture_output=True, text=True, check=True)
    return set(out.stdout.split())


def test_import_solver_loads_no_xarray_dask_or_study():
    loaded = _loaded_after("import rimroll.solver")
    assert not loaded & {"xarray", "dask", "distributed", "netCDF4", "study", "workflows", "matplotlib"}, loaded


def test_importing_the_study_layer_imports_no_workflows_module():
    modules = sorted(p.stem for p in (ROOT / "study").glob("*.py") if p.stem not in ("__main__",))
    imports = [f"import rimroll.study.{m}" if m != "__init__" else "import rimroll.study" for m in modules]
    loaded = _loaded_after("\n".join(imports))
    assert "study" in loaded and "workflows" not in loaded


def test_import_study_and_its_command_line_load_no_workflows_module():
    """``import study`` and the CLI module alone (what ``study --help`` costs) import no studies."""
    assert "workflows" not in _loaded_after("import rimroll.study")
    assert "workflows" not in _loaded_after("import rimroll.study.cli")


def test_study_sources_never_name_the_workflows_package():
    for path in (ROOT / "study").glob("*.py"):
        assert not re.search(r"^\s*(import|from)\s+(rimroll\.)?workflows\b", path.read_text(), re.M), path.name


def test_study_modules_import_no_cycle():
    """The modules of ``study`` import each other without a cycle (read from their sources: every
    ``from rimroll.study import x`` / ``from rimroll.study.x import`` / ``import rimroll.study.x``, at any depth)."""
    sources = {p.stem: p.read_text() for p in (ROOT / "study").glob("*.py") if p.stem != "__main__"}
    edges = {}
    for name, text in sources.items():
        found = set(re.findall(r"^\s*(?:from|import)\s+rimroll\.study\.(\w+)", text, re.M))
        for group in re.findall(r"^\s*from\s+rimroll\.study\s+import\s+\(?([\w\s,]+?)\)?\s*$", text, re.M):
            found |= {w.split(" as ")[0].strip() for w in group.split(",")}
        edges[name] = {m for m in found if m in sources and m != name}
    state = {}

    def visit(node, path):
        if state.get(node) == "done":
            return
        assert state.get(node) != "open", f"import cycle: {' -> '.join(path + [node])}"
        state[node] = "open"
        for nxt in sorted(edges[node]):
            visit(nxt, path + [node])
        state[node] = "done"

    for node in sorted(edges):
        visit(node, [])


def test_studies_are_found_through_the_entry_point_group():
    from rimroll.study import registry

    pyproject = (ROOT / "pyproject.toml").read_text()
    assert '[project.entry-points."rimroll.studies"]' in pyproject
    entries = {ep.name: ep.value for ep in registry.study_entry_points()}  # installed metadata
    names = registry.names()
    assert {"fig8", "fig11", "work-precision"} <= set(names)
    for name in names:  # one entry per study of rimroll's, naming the module that registers it
        module = registry.get(name).compute.__module__
        if module.startswith("rimroll.workflows."):  # (other tests register studies of their own)
            assert entries.get(name) == module, name
    assert set(entries) <= set(names)


def test_getting_a_study_imports_only_its_own_module():
    """A warm `study run fig11` skips the imports of the other study families."""
    code = ("import sys; from rimroll.study import registry; registry.get('fig11')\n"
            "print(sorted(m for m in sys.modules if m.startswith('rimroll.workflows.')))\n")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True, cwd=ROOT)
    # its family module only (what it is built on, the outcome sections, adaptive maps and boundary
    # curves, lives in the study layer and the solver), no other family
    assert out.stdout.strip() == "['rimroll.workflows.outcome_grids']"


def _contract(name_start: str) -> dict:
    """The import-linter contract of pyproject.toml whose name starts with ``name_start``."""
    import tomllib

    contracts = tomllib.loads((ROOT / "pyproject.toml").read_text())["tool"]["importlinter"]["contracts"]
    found = [c for c in contracts if c["name"].startswith(name_start)]
    assert len(found) == 1, name_start
    return found[0]


def test_the_independence_contract_lists_every_module_of_workflows():
    """workflows/ holds studies only, and each one is in the contract that keeps the families apart:
    a new module there fails here until pyproject.toml lists it."""
    modules = {f"rimroll.workflows.{p.stem}" for p in (ROOT / "workflows").glob("*.py") if p.stem != "__init__"}
    listed = set(_contract("The study families never import each other")["modules"])
    assert listed == modules, (sorted(modules - listed), sorted(listed - modules))


def _package_modules() -> dict[str, list[str]]:
    """{file name: [paths]} of every module of the installed package, read from pyproject.toml's package-dir
    (the folders of the floors: src/rimroll, solver, study, workflows, benchmarks/peer_models)."""
    import tomllib

    folders = tomllib.loads((ROOT / "pyproject.toml").read_text())["tool"]["setuptools"]["package-dir"].values()
    names: dict[str, list[str]] = {}
    for folder in folders:
        for path in sorted((ROOT / folder).rglob("*.py")):
            if path.name not in ("__init__.py", "__main__.py", "_version.py"):
                names.setdefault(path.name, []).append(path.relative_to(ROOT).as_posix())
    return names


def test_no_two_modules_share_a_name_across_the_floors():
    """One meaning per name: a module's file name is unique in the package (e.g. the scipy reference
    integrator solver/analysis/scipy_reference.py beside the stored reference slices study/reference.py)."""
    names = _package_modules()
    assert len(names) > 50 and "simulate.py" in names  # the folders were read
    clashes = {name: paths for name, paths in names.items() if len(paths) > 1}
    assert not clashes, clashes



def test_no_entry_points_is_one_line_error(monkeypatch, capsys):
    """An environment where no package declares the group (rimroll not installed): one line, exit 2."""
    from rimroll.study import registry
    from rimroll.study.cli import main

    monkeypatch.setattr(registry, "_REGISTRY", {})
    monkeypatch.setattr(registry, "_loaded_entry_points", False)
    monkeypatch.setattr(registry, "study_entry_points", lambda: [])
    monkeypatch.delenv(registry.PLUGIN_ENV, raising=False)
    for argv in (["list"], ["run", "fig8", "--quick"], ["info", "fig8"]):
        assert main(argv) == 2
        err = capsys.readouterr().err
        assert err.count("\n") == 1 and "no studies found" in err and "rimroll.studies" in err, err


def test_an_import_that_ctrl_c_broke_is_an_interrupt_not_a_broken_study(monkeypatch, capsys):
    """Ctrl-C while a compiled extension initialises (matplotlib's turn it into ImportError
    "initialization failed") is 'study: interrupted', exit 130; a module that fails to import for
    another reason stays a one-line error, exit 2."""
    from rimroll.study import registry
    from rimroll.study.cli import main

    class EntryPoint:
        def __init__(self, name, cause):
            self.name, self.value, self.cause = name, f"probe_module_{name}", cause

        def load(self):
            try:
                raise self.cause
            except BaseException as exc:
                raise ImportError("initialization failed") from exc

    points = [EntryPoint("probe-interrupted", KeyboardInterrupt()), EntryPoint("probe-broken", ValueError("bad"))]
    monkeypatch.setattr(registry, "study_entry_points", lambda: points)
    monkeypatch.setattr(registry, "_loaded_entry_points", False)  # an earlier test may have loaded them all
    assert main(["run", "probe-interrupted", "--quick"]) == 130
    err = capsys.readouterr().err
    assert err == "study: interrupted\n", err
    assert main(["run", "probe-broken", "--quick"]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "cannot load the studies of entry point probe-broken" in err, err


def test_a_lazy_import_that_ctrl_c_broke_during_a_command_is_an_interrupt(monkeypatch, capsys):
    """The same for an import during the command (the figure's backend): exit 130, one line."""
    from rimroll.study import cli

    def broken_import(args, command):
        try:
            raise KeyboardInterrupt
        except KeyboardInterrupt as exc:
            raise ImportError("initialization failed") from exc

    monkeypatch.setattr(cli, "_dispatch", broken_import)
    assert cli.main(["list"]) == 130
    assert capsys.readouterr().err == "study: interrupted\n"
    monkeypatch.setattr(cli, "_dispatch", lambda args, command: __import__("no_such_module_of_rimroll"))
    with pytest.raises(ImportError):  # any other ImportError is a bug, reported as such
        cli.main(["list"])
