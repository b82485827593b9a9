"""Opening rimroll files (``study.io``): a foreign, edited or bit-flipped file is refused in one line or
read unchanged.
"""

from __future__ import annotations

import numpy as np
import pytest
import xarray as xr

from rimroll.study.cli import main
from tests.helpers.study_runs import EDITS, bit_flipped_copy, edited_copy, one_line_error


@pytest.mark.parametrize("command", ["info", "plot", "verify"])
@pytest.mark.parametrize("edit", sorted(EDITS))
def test_foreign_or_edited_files_are_one_line(fig8_file, tmp_path, capsys, command, edit):
    change, needle = EDITS[edit]
    path = edited_copy(fig8_file, tmp_path / "fig8.nc", change)
    assert main([command, str(path)]) == 2
    one_line_error(capsys.readouterr().err, str(path), needle)
    assert not (tmp_path / "fig8.png").exists()


def test_bit_flipped_files_are_refused_or_unchanged(fig8_file, tmp_path, capsys):
    """Seeded random bit flips anywhere in a result: each command either refuses the file in one line
    (exit 2) or the flips hit no value or attribute (free space) and it answers as for the good file."""
    rng = np.random.default_rng(28)
    refused = 0
    with xr.open_dataset(fig8_file) as good:
        good = good.load()
    for k in range(24):
        path = bit_flipped_copy(fig8_file, tmp_path / f"f{k}.nc", rng)
        for command in ("info", "verify"):
            status = main([command, str(path)])
            captured = capsys.readouterr()
            assert "Traceback" not in captured.err
            if status == 2:
                one_line_error(captured.err, str(path))
                refused += 1
                continue
            assert status == main([command, str(fig8_file)]), (k, command)
            capsys.readouterr()
            with xr.open_dataset(path) as ds:
                assert ds.load().identical(good), k  # accepted only when nothing that is read changed
    assert refused > 0


def test_select_of_a_non_finite_value_is_one_line():
    from rimroll.study.cli import _selection
    from rimroll.study.registry import UserError

    ds = xr.Dataset(coords={"j": ("j", [0.4, 0.5])}, attrs={"swept": "j"})
    for value in ("nan", "inf", "-inf"):
        with pytest.raises(UserError, match="finite"):
            _selection([f"j={value}"], ds)
    mu = xr.Dataset(coords={"mu": ("mu", [1.0, np.inf])}, attrs={"swept": "mu"})
    assert _selection(["mu=inf"], mu) == {"mu": np.inf}  # an axis that holds inf (rolling only)
    with pytest.raises(UserError, match="finite"):
        _selection(["mu=nan"], mu)
