"""What a running command says while it works (``study.progress``): the estimate of a long run, the
time left, a notice while a long chunk computes.
"""

from __future__ import annotations

from rimroll.study import registry
from rimroll.study.cli import main
from rimroll.study.plan import make_plan
from tests.helpers.paths import HELPERS


def test_the_time_left_leaves_out_the_chunks_that_waited_for_the_compile():
    """A first run's first chunk on each thread includes the kernels' compile: 32 s per chunk there
    and 2 s after said 'about 4 min left' for a run that took 35 s (found by a new user)."""
    from rimroll.study import run_notices

    assert run_notices.seconds_per_chunk([32.0, 31.0], 2, 16) is None  # one round: wait for the next
    assert run_notices.seconds_per_chunk([32.0, 31.0, 2.0], 2, 16) is None
    assert run_notices.seconds_per_chunk([32.0, 31.0, 2.0, 2.5], 2, 16) == 2.25
    assert run_notices.seconds_per_chunk([3.0], 2, 1) == 3.0  # fewer chunks than two rounds: what there is


def test_estimate_line_only_for_long_runs(probe):
    import io as _io

    from rimroll.study import run_notices

    plan = make_plan(probe)
    quiet, loud = _io.StringIO(), _io.StringIO()
    run_notices.estimate(plan, 0.5, 100, 2, stream=quiet)  # 25 s: nothing to say
    run_notices.estimate(plan, 2.0, 5400, 2, stream=loud)  # 5400 s of work left
    assert quiet.getvalue() == ""
    assert loud.getvalue() == "study: fanout-probe: about 1.5 h left for 5400 chunks (2 s per chunk on 2 threads)\n"


def test_a_chunk_that_takes_long_is_not_silent(tmp_path, capsys, monkeypatch):
    """One worker, chunks of 2.5 s: a "working" notice within the first chunk, the run ends fine."""
    probe = str(HELPERS / "fanout_probe.py")
    monkeypatch.setenv(registry.PLUGIN_ENV, probe)
    argv = ["run", "fanout-probe", "--set", "mu=1", "--set", "v_throw=1", "--set", "delay=2.5",
            "--workers", "1", "--no-progress", "--out", str(tmp_path)]
    assert main(argv) == 0
    err = capsys.readouterr().err
    assert "fanout-probe: working, 0 of 2 chunks done after 2 s" in err, err
