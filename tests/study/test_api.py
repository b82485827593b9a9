"""The Python API: rimroll.run / open / studies on the path of `study run`, notices through
logging, lane summaries through warnings, a progress display that works in a notebook.

Most runs use the test-only ``fanout-probe`` study (``tests/helpers/fanout_probe.py``) and fig8 --quick.
"""

from __future__ import annotations

import os
import pathlib
import subprocess
import sys
import warnings

import numpy as np
import pytest
import xarray as xr

import rimroll
from rimroll.study import registry
from rimroll.study.cli import main
from rimroll.study.registry import PLUGIN_ENV, UserError
from tests.helpers.paths import HELPERS

PROBE = str(HELPERS / "fanout_probe.py")


def _python(code: str, **env) -> subprocess.CompletedProcess:
    return subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=120,
                          env={**os.environ, **env})


def test_import_rimroll_loads_no_numerics():
    run = _python("import sys, rimroll; rimroll.LaneStatusWarning; "
                  "print(sorted(m for m in ('numpy', 'xarray', 'dask', 'numba', 'rimroll.study') if m in sys.modules))")
    assert run.returncode == 0 and run.stdout.strip() == "[]", run.stderr
    assert callable(rimroll.run) and callable(rimroll.open) and "run" in dir(rimroll)
    assert dir(rimroll) == sorted(rimroll.__all__)  # not the helpers it imports (version, install, importlib)


def test_studies_lists_every_study_with_its_title():
    found = rimroll.studies()
    assert list(found)[:3] == ["fig3", "fig5", "fig6"] and "outcome-cube" in found
    assert found["fig8"] == registry.get("fig8").title


def test_studies_imports_no_studies_module_and_says_what_the_modules_say():
    """Listing the studies reads the catalogue (2.8-4 s of imports before, 0.8-1.5 s after, measured on a loaded
    2-core machine); the titles, names and order are those of the studies' modules."""
    code = ("import sys, rimroll; found = rimroll.studies(); "
            "print(sorted(m for m in sys.modules if m.startswith('rimroll.workflows')) or 'none', list(found))")
    run = _python(code)
    assert run.returncode == 0 and run.stdout.startswith("none "), run.stdout + run.stderr
    modules = {name: registry.get(name).title for name in registry.names()}  # every studies module imported
    assert run.stdout.strip() == f"none {registry.natural_order(modules)!r}"
    assert rimroll.studies() == modules


def test_studies_lists_a_plugins_study_from_its_module(probe):
    found = rimroll.studies()
    assert found["fanout-probe"] == probe.title and list(found)[:3] == ["fig3", "fig5", "fig6"]


def test_run_in_memory_equals_study_run(tmp_path):
    assert main(["run", "fig8", "--quick", "--set", "v_throw=7", "--out", str(tmp_path), "--no-progress"]) == 0
    ds = rimroll.run("fig8", quick=True, v_throw=7, progress=False)
    assert isinstance(ds, xr.Dataset) and not list(tmp_path.glob(".parts"))
    with xr.open_dataset(tmp_path / "fig8.nc") as cli:
        assert ds.attrs["run_fingerprint"] == cli.attrs["run_fingerprint"]
        for name in ("region", "omega20"):
            np.testing.assert_array_equal(ds[name].values, cli[name].values)
    assert ds.attrs["history"].endswith(f"rimroll.run('fig8', quick=True, v_throw=7) - rimroll {rimroll.__version__}"
                                        + (f" (git {ds.attrs['git_revision']})" if "git_revision" in ds.attrs else ""))


def test_run_into_out_reuses_refuses_and_forces(probe, tmp_path):
    log = tmp_path / "log.txt"
    ds = rimroll.run("fanout-probe", out=tmp_path, mu=[0.5, 1], v_throw=2, log=str(log), progress=False)
    assert ds.sizes["mu"] == 2 and "v_throw" not in ds.dims and ds["f"].chunks is not None  # lazy, from the file
    n = len(log.read_text().splitlines())
    ds.close()
    again = rimroll.run("fanout-probe", out=tmp_path, mu=[0.5, 1], v_throw=2, log=str(log))
    assert len(log.read_text().splitlines()) == n  # the same fingerprint: reused, nothing computed
    again.close()
    with pytest.raises(UserError, match="holds another run"):
        rimroll.run("fanout-probe", out=tmp_path, mu=[0.5, 2], v_throw=2, log=str(log))
    rimroll.run("fanout-probe", out=tmp_path, mu=[0.5, 2], v_throw=2, log=str(log), force=True).close()
    assert len(log.read_text().splitlines()) == 2 * n


def test_run_resumes_the_parts_of_an_interrupted_run(probe, tmp_path):
    """Parts saved by `study run` (stopped with FANOUT_PROBE_FAIL_MU) are resumed by rimroll.run."""
    log = tmp_path / "log.txt"
    env = {**os.environ, PLUGIN_ENV: PROBE, "FANOUT_PROBE_FAIL_MU": "2.0"}
    run = subprocess.run([sys.executable, "-m", "rimroll.study", "run", "fanout-probe", "--out", str(tmp_path),
                          "--set", f"log={log}", "--workers", "1", "--no-progress"],
                         capture_output=True, text=True, timeout=120, env=env)
    assert run.returncode != 0 and not (tmp_path / "fanout-probe.nc").exists()
    before = log.read_text().splitlines()
    ds = rimroll.run("fanout-probe", out=tmp_path, log=str(log), workers=1)
    after = log.read_text().splitlines()[len(before):]
    assert all(line.startswith("2.0 ") for line in after) and len(after) == 4  # only the chunks of mu = 2
    assert ds.sizes == {"mu": 3, "v_throw": 2, "x": 8, "y": 3}
    ds.close()


def test_run_refuses_bad_input_in_one_line_before_any_work(probe, tmp_path):
    with pytest.raises(UserError, match="unknown setting 'nope'"):
        rimroll.run("fanout-probe", out=tmp_path, nope=1)
    with pytest.raises(UserError, match="no study named|unknown study|not a study"):
        rimroll.run("no-such-study")
    with pytest.raises(UserError, match="workers= is for local runs"):
        rimroll.run("fanout-probe", workers=2, scheduler="tcp://127.0.0.1:1")
    with pytest.raises(UserError, match="expected a number, a label"):
        rimroll.run("fanout-probe", mu={"a": 1})
    with pytest.raises(UserError, match="^setting mu=abc: expected a number") as bad:  # not the CLI's --set
        rimroll.run("fanout-probe", mu="abc")
    assert "--set" not in str(bad.value)
    assert not list(tmp_path.iterdir())
    assert rimroll.UserError is UserError and "UserError" in rimroll.__all__  # catchable from the top


@pytest.mark.parametrize("kwargs, message", [
    ({"workers": "2"}, "workers must be an integer between 1 and"),
    ({"workers": True}, "workers must be an integer"),
    ({"out": 3}, "out must be a path"),
    ({"quick": "no"}, "quick must be True or False; got 'no'"),
    ({"force": 1}, "force must be True or False"),
    ({"plot": None}, "plot must be True or False"),
    ({"progress": "yes"}, "progress must be True or False"),
    ({"timeout": "5"}, "timeout must be a number of seconds"),
    ({"mu": []}, r"setting mu=\[\]: an empty list"),
    ({"mu": [[0.5, 1.0], [2.0, 4.0]]}, "must be flat"),
    ({"client": 3}, "client must be a dask.distributed.Client"),
    ({"client": "tcp://127.0.0.1:1"}, "client must be a dask.distributed.Client .*scheduler="),
])
def test_run_names_a_bad_argument_and_raises_a_value_error(probe, tmp_path, kwargs, message):
    """The API's errors are ValueErrors (UserError is one) naming the keyword, before any work."""
    with pytest.raises(ValueError, match=message) as bad:
        rimroll.run("fanout-probe", **kwargs)
    assert isinstance(bad.value, UserError) and "--" not in str(bad.value)


def test_an_interrupted_run_is_a_keyboard_interrupt_saying_what_was_saved(probe, tmp_path, monkeypatch):
    """Ctrl-C in a notebook stops rimroll.run as a KeyboardInterrupt (``except ValueError`` around the
    call does not swallow it), its message saying what was saved."""
    from rimroll.study import fanout, run_notices

    def stopped(*args, **kwargs):
        raise KeyboardInterrupt

    monkeypatch.setattr(fanout, "run", stopped)
    with pytest.raises(KeyboardInterrupt, match="interrupted; 0 of .* chunks saved") as stop:
        rimroll.run("fanout-probe", out=tmp_path)
    assert isinstance(stop.value, run_notices.RunInterrupted) and not isinstance(stop.value, ValueError)
    # without out= the chunks were in a temporary folder, deleted: it says so, not 'saved ... resume'
    with pytest.raises(KeyboardInterrupt, match="^interrupted; without out= nothing is kept") as stop:
        rimroll.run("fanout-probe")
    assert "saved" not in str(stop.value)


@pytest.mark.parametrize("path", [3, "", None])
def test_open_names_a_path_that_is_not_one(path):
    with pytest.raises(ValueError, match="path must be a path"):
        rimroll.open(path)


def test_run_hands_its_settings_on_as_values_never_as_text(probe, monkeypatch):
    """rimroll.run passes its keywords to make_plan as they are; the plan of those values is the plan of
    the command line's words (read once by ``cli_text.setting_values``)."""
    from rimroll.study import api, cli_text
    from rimroll.study.plan import make_plan

    seen = {}

    def capture(study, quick, values, local=True):
        seen.update(values)
        return make_plan(study, quick, values, local)

    monkeypatch.setattr(api, "make_plan", capture)
    mu = np.array([0.25, 1.0])
    with pytest.raises(UserError, match=r"j=0.4:0.6:5: expected a number \(a range is a list or numpy.linspace"):
        rimroll.run("fanout-probe", mu=mu, j="0.4:0.6:5")
    assert seen["mu"] is mu and seen["j"] == "0.4:0.6:5"
    values = {"mu": mu, "v_throw": range(1, 4), "n_x": 8, "j": np.linspace(0.4, 0.6, 5), "k_r": 0}
    words = cli_text.setting_values(probe, ["mu=0.25,1.0", "v_throw=1:3:3", "n_x=8", "j=0.4:0.6:5", "k_r=0"])
    assert words == {"mu": (0.25, 1.0), "v_throw": (1.0, 2.0, 3.0), "n_x": 8, "j": tuple(np.linspace(0.4, 0.6, 5)),
                     "k_r": 0.0}
    assert make_plan(probe, False, values).fingerprint == make_plan(probe, False, words).fingerprint


def test_open_reads_a_result_lazily_or_loaded(tmp_path):
    assert main(["run", "fig8", "--quick", "--out", str(tmp_path), "--no-progress"]) == 0
    with rimroll.open(tmp_path / "fig8.nc") as ds:
        assert ds["omega20"].chunks is not None
    loaded = rimroll.open(str(tmp_path / "fig8.nc"), lazy=False)
    assert loaded["omega20"].chunks is None
    with pytest.raises(UserError, match="no such results file"):
        rimroll.open(tmp_path / "nothing.nc")


# ---------------------------------------------------------------- messages: logging and warnings

NOTICE = ("import logging, rimroll\n"
          "{setup}\n"
          "logging.getLogger('rimroll.solver.engine.simulate').info('compiling the probe kernel')\n"
          "logging.getLogger('rimroll.study.run_notices').info('probe: 100 of 100 chunks to compute')\n")


def test_notices_go_to_stderr_until_silenced_with_the_standard_logging_call():
    shown = _python(NOTICE.format(setup=""))
    assert shown.stderr.splitlines() == ["rimroll: compiling the probe kernel",
                                         "study: probe: 100 of 100 chunks to compute"], shown.stderr
    quiet = _python(NOTICE.format(setup="logging.getLogger('rimroll').setLevel(logging.WARNING)"))
    assert quiet.returncode == 0 and quiet.stderr == ""


def test_notices_go_through_the_applications_logging_once_it_is_configured():
    routed = _python(NOTICE.format(setup="logging.basicConfig(format='%(name)s|%(levelname)s|%(message)s')"))
    assert routed.stderr.splitlines() == ["rimroll.solver.engine.simulate|INFO|compiling the probe kernel",
                                          "rimroll.study.run_notices|INFO|probe: 100 of 100 chunks to compute"]


def test_lanes_not_ok_are_a_warning_of_rimrolls_own_category(tmp_path):
    from rimroll.study import api

    path = tmp_path / "lanes.nc"
    status = xr.DataArray(np.array([0, 0, 2, 3], dtype="int8"), dims="x",
                          attrs={"flag_values": np.array([0, 1, 2, 3], dtype="int8"),
                                 "flag_meanings": "ok max_steps non_finite step_too_small"})
    xr.Dataset({"status": status}).to_netcdf(path)
    with pytest.warns(rimroll.LaneStatusWarning, match=r"2 of 4 lanes of run\(x\) did not finish ok "
                                                       r"\(1 non_finite, 1 step_too_small\)"):
        api._warn_lanes(path, "run(x)")
    assert issubclass(rimroll.LaneStatusWarning, rimroll.RimrollWarning)
    with warnings.catch_warnings():
        warnings.filterwarnings("error", category=rimroll.LaneStatusWarning)
        with pytest.raises(rimroll.LaneStatusWarning):
            api._warn_lanes(path, "run(x)")


# ---------------------------------------------------------------- progress in a notebook and a terminal

class _Handle:
    def __init__(self, shown):
        self.shown = shown

    def update(self, bundle, raw=False):
        self.shown.append(("update", bundle))


def test_progress_in_a_notebook_is_one_cell_output_updated_in_place():
    from rimroll.study.progress import ProgressLine

    shown = []

    def display(bundle, raw=False, display_id=False):
        assert raw and display_id
        shown.append(("display", bundle))
        return _Handle(shown)

    line = ProgressLine(4, "probe", minimum=0.0, display=display)
    for _ in range(4):
        line.advance()
        line.last = -1.0  # no 0.2 s throttle in the test
    line.close()
    assert [kind for kind, _ in shown] == ["display", "update", "update", "update"]
    last = shown[-1][1]
    assert last["text/plain"].startswith("study: probe chunks 4/4")
    assert '<progress value="4" max="4"' in last["text/html"]


def test_progress_in_a_terminal_redraws_one_line(monkeypatch):
    import io

    from rimroll.study import progress

    stream = io.StringIO()
    line = progress.ProgressLine(2, "probe", minimum=0.0, stream=stream)
    line.advance()
    line.advance()
    line.close()
    assert stream.getvalue().startswith("\rstudy: probe chunks 1/2") and stream.getvalue().endswith("\n")
    monkeypatch.setattr(progress, "in_notebook", lambda: True)
    assert progress.wanted(None) and not progress.wanted(False)


def _held_lock(out: pathlib.Path, study: str):
    """The lock of ``<out>/<study>.nc`` held (as a run holds it, with its process id), as an open file."""
    import fcntl

    (out / ".parts").mkdir(parents=True)
    held = open(out / ".parts" / f"{study}.lock", "w")
    fcntl.flock(held, fcntl.LOCK_EX | fcntl.LOCK_NB)
    held.write(f"{os.getpid()}\n")
    held.flush()
    return held


def test_opening_a_result_its_run_is_writing_names_the_run(tmp_path, capsys):
    """The file is written whole when the run ends: until then, rimroll.open and study info say that a run
    is writing it and name its lock, not only "no such results file"."""
    with _held_lock(tmp_path, "fig11"):
        with pytest.raises(UserError) as err:
            rimroll.open(tmp_path / "fig11.nc")
        assert main(["info", str(tmp_path / "fig11.nc")]) == 2
    text = " ".join(str(err.value).split())
    assert "a run of 'fig11' is writing it" in text and str(tmp_path / ".parts" / "fig11.lock") in text
    assert f"by process {os.getpid()}" in text
    assert "a run of 'fig11' is writing it" in capsys.readouterr().err
    with pytest.raises(UserError) as err:  # the run has finished (its lock released) without the file
        rimroll.open(tmp_path / "fig11.nc")
    assert "writing" not in str(err.value)


def test_the_api_refuses_a_concurrent_run_in_its_own_words(tmp_path, probe):
    with _held_lock(tmp_path, "fanout-probe"):
        with pytest.raises(UserError) as err:
            rimroll.run("fanout-probe", out=tmp_path)
    text = str(err.value)
    assert "is in progress" in text and "another out=" in text and "--out" not in text
