"""Layering: ``solver`` is pure numpy (no xarray, dask, study); ``study`` finds the studies through
the ``rimroll.studies`` entry-point group and never imports ``workflows`` itself."""

from __future__ import annotations

import pathlib
import re
import subprocess
import sys

ROOT = pathlib.Path(__file__).resolve().parent.parent


def _loaded_after(statement: str) -> set[str]:
    code = f"import sys\n{statement}\nprint(' '.join(sorted({{m.split('.')[0] for m in sys.modules}})))"
    out = subprocess.run([sys.executable, "-c", code], cwd=ROOT, capture_output=True, text=True, check=True)
    return set(out.stdout.split())


def test_import_solver_loads_no_xarray_dask_or_study():
    loaded = _loaded_after("import solver")
    assert not loaded & {"xarray", "dask", "distributed", "netCDF4", "study", "workflows", "matplotlib"}, loaded


def test_importing_the_study_layer_imports_no_workflows_module():
    modules = sorted(p.stem for p in (ROOT / "study").glob("*.py") if p.stem not in ("__main__",))
    loaded = _loaded_after("\n".join(f"import study.{m}" if m != "__init__" else "import study" for m in modules))
    assert "study" in loaded and "workflows" not in loaded


def test_study_sources_never_name_the_workflows_package():
    for path in (ROOT / "study").glob("*.py"):
        assert not re.search(r"^\s*(import|from)\s+workflows\b", path.read_text(), re.M), path.name


def test_studies_are_found_through_the_entry_point_group():
    from study import registry

    assert "workflows" in registry.study_modules()
    pyproject = (ROOT / "pyproject.toml").read_text()
    assert '[project.entry-points."rimroll.studies"]' in pyproject
    assert {"fig8", "fig11", "work-precision"} <= set(registry.names())
