"""Both CF checkers pass every study's ``--quick`` file: the IOOS compliance-checker
(``cf:1.8``) and the CF Checker (cfchecker, ``cfchecks``), as the files declare ``Conventions =
"CF-1.8"`` (the newest version cfchecker knows). Slow (every study runs, about 2 min warm):
``python -m pytest -m slow tests/study/test_cf_checkers.py``; needs the extra ``rimroll[cf]`` and the
UDUNITS-2 library that cfchecker loads (Debian: ``apt install libudunits2-0``), else skipped with
the reason. No network: the standard-name table is compliance-checker's copy; the area-type and
region tables (no rimroll file uses them) are minimal ones written here.
"""

from __future__ import annotations

import contextlib
import io
import json
import os
import pathlib
import subprocess
import sys

import pytest

from rimroll.study import registry

pytestmark = pytest.mark.slow

STUDIES = registry.names()
TABLE = """<?xml version="1.0"?>
<{root}><version_number>1</version_number><date>2024-01-01</date><entry id="{entry}"></entry></{root}>
"""


def _checkers_or_skip() -> pathlib.Path:
    """compliance-checker's standard-name table; skip when a checker cannot run here."""
    try:
        import compliance_checker
    except ImportError:
        pytest.skip("needs compliance-checker (pip install 'rimroll[cf]')")
    probe = subprocess.run([sys.executable, "-c", "import cfchecker.cfchecks"], capture_output=True, text=True,
                           timeout=60)
    if probe.returncode:
        reason = probe.stderr.strip().splitlines()[-1] if probe.stderr.strip() else "cannot import cfchecker"
        pytest.skip(f"needs cfchecker and the UDUNITS-2 library (pip install 'rimroll[cf]'; "
                    f"apt install libudunits2-0): {reason}")
    return pathlib.Path(compliance_checker.__file__).parent / "data" / "cf-standard-name-table.xml"


@pytest.fixture(scope="module")
def quick_files(tmp_path_factory):
    names = _checkers_or_skip()
    root = tmp_path_factory.mktemp("cf")
    for name in STUDIES:
        run = subprocess.run([sys.executable, "-m", "rimroll.study", "run", name, "--quick", "--out", str(root),
                              "--no-progress"], capture_output=True, text=True, timeout=600, env=dict(os.environ))
        assert run.returncode == 0, (name, run.stderr)
    (root / "area.xml").write_text(TABLE.format(root="area_type_table", entry="all_area_types"))
    (root / "region.xml").write_text(TABLE.format(root="standardized_region_list", entry="global"))
    return root, names


@pytest.mark.parametrize("name", STUDIES)
def test_compliance_checker_finds_no_error(quick_files, name):
    root, _ = quick_files
    from compliance_checker.runner import CheckSuite, ComplianceChecker

    report = root / f"{name}.cc.json"
    CheckSuite().load_all_available_checkers()
    with contextlib.redirect_stdout(io.StringIO()) as said, contextlib.redirect_stderr(said):
        ComplianceChecker.run_checker(str(root / f"{name}.nc"), ["cf:1.8"], 0, "normal",
                                      output_filename=str(report), output_format="json_new")
    assert "exceptions occurred" not in said.getvalue(), said.getvalue()
    result = next(iter(json.loads(report.read_text()).values()))["cf:1.8"]
    errors = [msg for item in result["high_priorities"] if item["value"][0] < item["value"][1] for msg in item["msgs"]]
    assert errors == [], errors


@pytest.mark.parametrize("name", STUDIES)
def test_cfchecker_finds_no_error(quick_files, name):
    root, names = quick_files
    run = subprocess.run([sys.executable, "-c", "import sys; from cfchecker.cfchecks import main; sys.exit(main())",
                          "-s", str(names), "-a", str(root / "area.xml"), "-r", str(root / "region.xml"),
                          str(root / f"{name}.nc")], capture_output=True, text=True, timeout=300)
    assert "Traceback" not in run.stderr, run.stderr
    assert "ERRORS detected: 0" in run.stdout, run.stdout
