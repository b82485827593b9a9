"""Runs you can trust, second round (issue 28): every bad setting, colliding path and damaged file
is one line ``study: error: ...`` and exit 2, before any work and with nothing half-written.

Each class is one generated list of cases (every setting of every study; every path the CLI
writes; every kind of damage to a file), not one test per example of the issue.
"""

from __future__ import annotations

import numpy as np
import pytest

from rimroll.study import registry
from rimroll.study.cli import main
from rimroll.study.registry import PHYSICAL_KEYS
from rimroll.study.setting_table import MAX_MAGNITUDE, ORDERED, lookup


def _one_line_error(err: str, *needles):
    lines = err.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("study: error:"), err
    assert "Traceback" not in err
    for needle in needles:
        assert needle in lines[0], (needle, lines[0])


def _studies():
    return [registry.get(n) for n in registry.names()
            if registry.get(n).compute.__module__.startswith("rimroll.workflows.")]


# ================================================================ 1. every setting checked before any work
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


@pytest.mark.parametrize("name, key, value", _numeric_cases())
def test_every_out_of_range_setting_is_one_line_before_any_work(tmp_path, capsys, name, key, value):
    out = tmp_path / "o"
    assert main(["run", name, "--quick", "--set", f"{key}={value}", "--out", str(out), "--no-progress"]) == 2
    _one_line_error(capsys.readouterr().err, key)
    assert not out.exists()


def test_the_magnitude_bound_is_the_readmes():
    for key in ("v_throw", "omega2", "omega3", "omega30", "sigma", "d_omega1"):
        assert lookup(key).problem(MAX_MAGNITUDE) is None and lookup(key).problem(1e13) is not None, key


@pytest.mark.parametrize("low, high, strict", ORDERED)
def test_ordered_pairs_are_checked_before_any_work(tmp_path, capsys, low, high, strict):
    study = next(s for s in _studies() if low in s.settings and high in s.settings)
    value = study.quick.get(high, study.settings[high])
    for bad in ([value] if strict else [value + 0.1]):
        out = tmp_path / "o"
        assert main(["run", study.name, "--quick", "--set", f"{low}={bad!r}", "--out", str(out)]) == 2
        _one_line_error(capsys.readouterr().err, low, high, "out of order")
        assert not out.exists()
