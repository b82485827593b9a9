"""Checks made before any work (``study.checks``, the setting table's ranges): a bad setting is one line,
exit 2, and nothing is written.
"""

from __future__ import annotations

import numpy as np
import pytest

from rimroll.study import registry
from rimroll.study.cli import main
from rimroll.study.registry import PHYSICAL_KEYS
from rimroll.study.setting_table import MAX_MAGNITUDE, ORDERED, lookup
from tests.helpers.study_runs import one_line_error


def _studies():
    return [registry.get(n) for n in registry.names()
            if registry.get(n).compute.__module__.startswith("rimroll.workflows.")]


def _numeric_cases():
    """(study, key, value) for every numeric setting of every study: beyond +-1e12 (finite, huge,
    as a list where the setting sweeps) and not a number. Friction coefficients, which take inf,
    are left out."""
    cases = []
    for study in _studies():
        keys = sorted({*study.settings, *study.quick} - set(study.ignores) - {"mu", "rho_over_R"})
        for key in keys:
            default = study.settings.get(key, study.quick.get(key))
            if isinstance(default, bool) or not isinstance(default, (int, float, tuple)) or key in PHYSICAL_KEYS:
                continue
            if lookup(key).range is not None and lookup(key).range.contains(np.inf):
                continue  # a friction coefficient: inf (and any large value) means never slipping
            cases += [(study.name, key, "1e13"), (study.name, key, "-1e300"), (study.name, key, "nan")]
            if key in study.sweepable:
                cases.append((study.name, key, "1e13,2e13"))
    return cases


# cases the generated ones do not hold: an open bound, a label, a friction coefficient, a setting the study
# does not use, the physical parameters (Params' own ranges: positive, below 1e12, as the README says of every
# number; j = 1e308 overflowed (1+j)**2 inside a chunk), two at once
OTHER_CASES = [
    ("outcome-cube", ("rtol=0",), "rtol"),
    ("fig11", ("method=rk4",), "dop853, dp5"),
    ("fig11", ("mu_slip=-1",), "mu_slip"),
    ("fig11", ("mu=2",), "does not use 'mu'"),
    ("fig5", ("mu=2",), "does not use 'mu'"),
    ("fig13", ("k_r=0.1",), "does not use 'k_r'"),
    ("fig5", ("j=1e308",), "1e12"),
    ("fig5", ("j=1e200", "g=1e200"), "1e12"),
    ("fig5", ("k_r=1e12",), "1e12"),
]


def _bad_setting_cases():
    """(study, --set items, what the line names): every numeric setting of every study out of range
    (``_numeric_cases``), then ``OTHER_CASES``."""
    return [pytest.param(name, (f"{key}={value}",), key, id=f"{name}-{key}={value}")
            for name, key, value in _numeric_cases()] + \
           [pytest.param(name, sets, needle, id="-".join((name, *sets))) for name, sets, needle in OTHER_CASES]


@pytest.mark.parametrize("name, sets, needle", _bad_setting_cases())
def test_a_bad_setting_is_one_line_before_any_work(tmp_path, capsys, name, sets, needle):
    out = tmp_path / "o"
    argv = ["run", name, "--quick", "--out", str(out), "--no-progress"]
    for item in sets:
        argv += ["--set", item]
    assert main(argv) == 2
    one_line_error(capsys.readouterr().err, needle)
    assert not out.exists()


def test_the_magnitude_bound_is_the_readmes():
    for key in ("v_throw", "omega2", "omega3", "omega30", "sigma"):
        assert lookup(key).problem(MAX_MAGNITUDE) is None and lookup(key).problem(1e13) is not None, key
    # d_omega1 has a range of its own: the integration's steps grow with it (setting_table)
    assert lookup("d_omega1").problem(100.0) is None and lookup("d_omega1").problem(100.5) is not None


@pytest.mark.parametrize("low, high, strict", ORDERED)
def test_ordered_pairs_are_checked_before_any_work(tmp_path, capsys, low, high, strict):
    study = next(s for s in _studies() if low in s.settings and high in s.settings)
    value = study.quick.get(high, study.settings[high])
    for bad in ([value] if strict else [value + 0.1]):
        out = tmp_path / "o"
        assert main(["run", study.name, "--quick", "--set", f"{low}={bad!r}", "--out", str(out)]) == 2
        one_line_error(capsys.readouterr().err, low, high, "out of order")
        assert not out.exists()
