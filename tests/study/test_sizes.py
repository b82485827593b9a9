"""Sizes that cannot fit are refused before the work, in one line naming the size and the limit.

One estimate of memory (``solver._arguments.check_size``) serves the solver's functions that allocate
by a count the caller gives; a swept setting's list is bounded (``checks.MAX_AXIS``) before its values
are read, and reading a long list is linear. The cases are generated from the machine's own limit
(so they cannot fit here, whatever the machine) and from every study's sweepable settings.
"""

from __future__ import annotations

import subprocess
import sys
import time

import numpy as np
import pytest

import rimroll
from rimroll.solver import Params
from rimroll.solver._arguments import check_size, memory_limit
from rimroll.solver.analysis import phase_trace as trace
from rimroll.solver.analysis import predictability
from rimroll.study import checks, cli_text, registry
from rimroll.study.cli import main
from rimroll.study.registry import UserError
from rimroll.study.setting_table import SWEEP_KEYS
from tests.helpers.study_runs import error_after_notices, one_line_error, run_probe

STATE = [1.2, 0.0, 65.0, 10.0]


def _beyond(values_per_item: int, itemsize: int = 8) -> int:
    """A count whose array of ``values_per_item`` values each cannot fit in this machine's limit."""
    return memory_limit() // (values_per_item * itemsize) + 1


SOLVER_CASES = {
    "make_probability n_samples (draws)": lambda: predictability.make_probability(
        [STATE], Params(), [0.01] * 4, n_samples=_beyond(4)),
    "make_probability n_samples (outcomes of 1000 states)": lambda: predictability.make_probability(
        np.tile(STATE, (1000, 1)), Params(), [0.01] * 4, n_samples=_beyond(1000)),
    "trace n": lambda: trace.trace(STATE, Params(), t_max=1.0, n=_beyond(trace.SAMPLED_COLUMNS)),
    "sample n": lambda: trace.sample({"t_end": 1.0, "phases": []}, Params(), n=_beyond(trace.SAMPLED_COLUMNS)),
}


@pytest.mark.parametrize("case", list(SOLVER_CASES))
def test_a_solver_size_beyond_memory_is_refused_first(case):
    start = time.perf_counter()
    with pytest.raises(ValueError, match=r"would take .* of memory; the limit is") as info:
        SOLVER_CASES[case]()
    assert time.perf_counter() - start < 5.0  # before the work (no integration, no allocation)
    assert "\n" not in str(info.value)


def test_the_limit_is_what_the_machine_has():
    limit = memory_limit()
    assert 1 << 28 <= limit  # at least a quarter GiB on any machine that runs rimroll
    check_size("n", (limit // 8,))  # exactly the limit fits
    with pytest.raises(ValueError, match="`n`"):
        check_size("n", (limit // 8 + 1,))


@pytest.mark.slow  # a fresh process: 5-9 s of imports; the same check in process: "trace n" above
def test_the_trace_command_refuses_samples_beyond_memory(tmp_path):
    n = _beyond(trace.SAMPLED_COLUMNS)
    run = subprocess.run([sys.executable, "-m", "rimroll.study", "trace", "--state", "1.2,0,65,10", "--samples",
                          str(n), "--out", str(tmp_path)], capture_output=True, text=True, timeout=120)
    assert run.returncode == 2
    lines = run.stderr.strip().splitlines()
    assert len(lines) == 1 and "--samples" in lines[0] and "the limit is" in lines[0], run.stderr
    assert not list(tmp_path.iterdir())


def _sweepable() -> list:
    """Every study with each sweepable setting of its own, and a physical parameter (mu: all take it)."""
    return [(name, key) for name in registry.names() for key in SWEEP_KEYS
            if key in registry.get(name).settings or key == "mu"]


@pytest.mark.parametrize("name,key", _sweepable())
def test_a_swept_list_beyond_the_axis_limit_is_refused_before_it_is_read(name, key):
    """An array, a list and a generator one value longer than MAX_AXIS: refused naming the size and
    the limit, without reading (or formatting) the values (a generator is not read to its end)."""
    too_many = checks.MAX_AXIS + 1
    read = []

    def values():
        for i in range(10 * too_many):
            read.append(i)
            yield 0.5

    for value in (np.full(too_many, 0.5), [0.5] * too_many, values()):
        with pytest.raises(UserError, match=rf"{key}.*at most {checks.MAX_AXIS}"):
            rimroll.run(name, quick=True, **{key: value})
    assert len(read) == checks.MAX_AXIS + 1


def test_a_generator_setting_is_read_once():
    """A generator is read once: its values reach the checks (not 'an empty list')."""
    with pytest.raises(UserError, match="mu=-1.0,-2.0") as info:
        rimroll.run("fig8", quick=True, mu=(v for v in (-1.0, -2.0)))
    assert "empty" not in str(info.value)


def test_splitting_a_long_list_is_linear():
    """--set KEY=v1,...,vN is read in time linear in N (it was quadratic: 1e5 values took ~100 s)."""
    word = "mu=" + ",".join(["0.5"] * 400_000)
    start = time.perf_counter()
    (key, value), = cli_text.split(word, "--set")
    assert time.perf_counter() - start < 10.0  # linear: ~0.3 s; quadratic: hours
    assert key == "mu" and value.count(",") == 399_999


def test_absurd_sizes_are_refused_at_once(probe, tmp_path, capsys):
    cases = [(["--workers", "1000000000000"], "--workers must be between 1 and"),
             (["--set", "mu=0.1:10:10000000"], "at most 100000 values"),
             (["--set", "mu=0.1:10:1000", "--set", "v_throw=1:2:1000"], "chunks"),
             (["--set", "n_x=1000000000"], "n_x")]
    for extra, expect in cases:
        t0 = time.monotonic()
        assert run_probe(tmp_path, *extra) == 2
        error_after_notices(capsys.readouterr().err, expect)
        assert time.monotonic() - t0 < 30, extra
    assert not list(tmp_path.iterdir())


def test_absurdly_large_runs_are_refused_with_the_bound(tmp_path, capsys):
    from rimroll.study import run_notices

    out = tmp_path / "o"
    argv = ["run", "make-probability", "--set", "n_beta=20000", "--set", "n_omega1=20000",
            "--set", "n_samples=100000", "--out", str(out)]
    assert main(argv) == 2
    one_line_error(capsys.readouterr().err, "of one core", run_notices._duration(run_notices.MAX_CORE_SECONDS))
    assert not (out / "make-probability.nc").exists() and not (out / ".parts").exists()
