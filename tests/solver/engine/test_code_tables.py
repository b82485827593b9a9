"""The solver's code tables, built by one helper (``solver.engine.outcomes.code_table``), read files written before
them the same way: the codes and CF flag attributes of the stored reference slices (written by earlier versions)
equal the tables' ones."""

from __future__ import annotations

import numpy as np
import pytest
import xarray as xr

from rimroll.solver.analysis import boundaries, solution_types
from rimroll.solver.engine import outcomes
from tests.helpers.paths import ROOT

SLICES = ROOT / "study" / "reference_slices"

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
    table = outcomes.code_table("""
low: below the line
high: above it: far,
    and further
""")
    assert table.meanings == {0: "low: below the line", 1: "high: above it: far, and further"}
    assert table.flag_values == (0, 1)
    assert table.flag_meanings == "low high"
    assert outcomes.flag_meanings(table.meanings) == table.flag_meanings


def test_every_table_codes_its_constants_in_order():
    assert (outcomes.FALL_IN, outcomes.STEADY_MOTION, outcomes.OK, outcomes.STIFF_SLIP, outcomes.STOPPED_EARLY) == (
        0, 4, 0, 5, 4)
    assert outcomes.OUTCOME_MEANINGS[outcomes.PERIODIC_ROLLING].startswith("periodic_rolling: ")
    assert boundaries.BOUNDARY_MEANINGS[boundaries.SEPARATRIX_AND_DEADLOCK].startswith("separatrix_and_deadlock: ")
    assert solution_types.TYPE_MEANINGS[solution_types.QUASI_PERIODIC].startswith("quasi_periodic: ")
    assert solution_types.CONNECTION_MEANINGS[solution_types.OTHER_END_UNRESOLVED].startswith("other_end_unresolved")


@pytest.mark.parametrize("text, says", [
    ("no colon here", "'name: meaning'"),
    ("two words: a name that is not one word", "one-word name"),
    ("same: one\nsame: two", "names repeat"),
])
def test_a_malformed_table_is_refused_in_one_line_naming_the_entry(text, says):
    with pytest.raises(ValueError, match=says) as err:
        outcomes.code_table(text)
    assert "\n" not in str(err.value)
