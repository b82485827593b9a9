"""The solver's code tables, built by one helper (``solver.engine.outcomes.code_table``), read files written before
them the same way: the codes and CF flag attributes of the stored reference slices (written by earlier versions)
equal the tables' ones."""

from __future__ import annotations

import pathlib

import numpy as np
import pytest
import xarray as xr

from rimroll.solver.analysis import boundaries, solution_types
from rimroll.solver.engine import outcomes

SLICES = pathlib.Path(__file__).resolve().parents[1] / "study" / "reference_slices"

STORED = [  # (reference slice, variable, the table that wrote it)
    ("fig11.nc", "outcome", (outcomes.OUTCOME_FLAG_VALUES, outcomes.OUTCOME_FLAG_MEANINGS)),
    ("fig11.nc", "status", (outcomes.STATUS_FLAG_VALUES, outcomes.STATUS_FLAG_MEANINGS)),
    ("fig11.nc", "on_rim_reason", (outcomes.ON_RIM_REASON_FLAG_VALUES, outcomes.ON_RIM_REASON_FLAG_MEANINGS)),
    ("fig11.nc", "boundary_type", (boundaries.BOUNDARY_FLAG_VALUES, boundaries.BOUNDARY_FLAG_MEANINGS)),
    ("solution-types.nc", "type", (solution_types.TYPE_FLAG_VALUES, solution_types.TYPE_FLAG_MEANINGS)),
    ("solution-types.nc", "connection",
     (solution_types.CONNECTION_FLAG_VALUES, solution_types.CONNECTION_FLAG_MEANINGS)),
]


@pytest.mark.parametrize("name, var, table", STORED, ids=[f"{n}:{v}" for n, v, _ in STORED])
def test_a_stored_file_reads_the_same_codes_and_flags(name, var, table):
    with xr.open_dataset(SLICES / name) as ds:
        attrs = ds[var].attrs
    values, meanings = table
    assert np.asarray(attrs["flag_values"]).tolist() == list(values)
    assert attrs["flag_meanings"] == meanings


def test_a_table_gives_its_meanings_codes_and_names_in_order():
    table = outcomes.code_table({0: "low: below the line", 3: "high: above it: far"})
    assert table.meanings == {0: "low: below the line", 3: "high: above it: far"}
    assert table.flag_values == (0, 3)
    assert table.flag_meanings == "low high"
    assert outcomes.flag_meanings(table.meanings) == table.flag_meanings


@pytest.mark.parametrize("meanings, says", [
    ({0: "no colon here"}, "'name: meaning'"),
    ({0: "two words: a name that is not one word"}, "one-word name"),
    ({"0": "zero: a string code"}, "an int code"),
    ({0: "same: one", 1: "same: two"}, "names repeat"),
])
def test_a_malformed_table_is_refused_in_one_line_naming_the_entry(meanings, says):
    with pytest.raises(ValueError, match=says) as err:
        outcomes.code_table(meanings)
    assert "\n" not in str(err.value)
