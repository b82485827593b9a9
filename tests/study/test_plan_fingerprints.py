"""Typed settings keep every plan's fingerprint: the plans of main's text-based settings (recorded in
``plan_fingerprints.json`` before ``make_plan`` took Python values) are the plans of today's values.

The fingerprints hold the code digest and the release fixed (``fixed_fingerprint``), so that they say
what typed settings could change (the study, the resolved settings and their types, Params, axes,
variables, chunking) and not the source of the solver or of a study, which other work changes.
"""

from __future__ import annotations

import json
import pathlib

import numpy as np
import pytest

from rimroll.study import cli_text, reference, registry
from rimroll.study import plan as plan_module
from rimroll.study.plan import make_plan

RECORD = json.loads((pathlib.Path(__file__).parent / "plan_fingerprints.json").read_text())


@pytest.fixture
def fixed_fingerprint(monkeypatch, probe_study):
    """The fingerprint of a plan with the code digest '0'*64 and the release '0.1' (as recorded)."""
    monkeypatch.setattr(plan_module, "rimroll_version", lambda: "0.1")

    def fingerprint(plan):
        plan.__dict__["digest"] = "0" * 64  # Plan.digest is a cached property: the recorded code digest
        return plan.fingerprint

    return fingerprint


def python_value(value):
    """A recorded value as a Python caller gives it: {'linspace': [a, b, n]} numpy.linspace, {'range':
    [a, b, step]} a range object, {'array': [...]} a numpy array, a list as a list."""
    if isinstance(value, dict):
        (kind, args), = value.items()
        return {"linspace": lambda: np.linspace(*args), "range": lambda: range(*args),
                "array": lambda: np.array(args)}[kind]()
    return value


@pytest.mark.parametrize("grid", ["quick", "default"])
def test_every_study_plan_keeps_its_fingerprint(fixed_fingerprint, grid):
    recorded = RECORD[grid]
    assert set(recorded) == set(registry.names())  # a study added or removed: record it
    for name, fingerprint in recorded.items():
        assert fixed_fingerprint(make_plan(registry.get(name), grid == "quick")) == fingerprint, name


@pytest.mark.parametrize("case", sorted(RECORD["cases"]))
def test_swept_and_labelled_settings_keep_their_fingerprint_as_values_and_as_words(fixed_fingerprint, case):
    """The Python values (a list, a range object, a numpy array, labels, switches) and the command line's
    words read once by ``cli_text.setting_values`` give the plan that main's words gave."""
    c = RECORD["cases"][case]
    study = registry.get(c["study"])
    values = {k: python_value(v) for k, v in c["values"].items()}
    assert fixed_fingerprint(make_plan(study, c["quick"], values)) == c["fingerprint"]
    words = cli_text.setting_values(study, c["words"])
    assert not any(isinstance(v, str) and v != values[k] for k, v in words.items())  # only labels stay text
    assert fixed_fingerprint(make_plan(study, c["quick"], words)) == c["fingerprint"]


def test_reference_slice_plans_keep_their_fingerprint(fixed_fingerprint):
    """The reference specs, dicts of values now, plan the slices that their ``--set`` items planned."""
    recorded = RECORD["reference"]
    got = {}
    for name in reference.specs():
        for grid in reference.GRIDS:
            for precise in (True, False):
                plan = reference.slice_plan(name, grid, precise)
                got[f"{name}/{grid}/{'precise' if precise else 'own'}"] = fixed_fingerprint(plan)
    assert got == recorded
