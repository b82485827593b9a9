"""A test-only study, ``fanout-probe``, for the fan-out tests (not registered by ``workflows``).

Load it in any process (the CLI, dask workers) by naming this file in the environment variable
``RIMROLL_STUDY_MODULES`` (see ``study.registry.PLUGIN_ENV``). Settings used by the tests:

- ``delay`` [s]: sleep per chunk, so that a run can be killed part-way;
- ``log``: a file to which every computed chunk appends one line ``mu v_throw x0`` (O_APPEND),
  so that a test can count which chunks were computed;
- environment ``FANOUT_PROBE_FAIL_MU``: compute raises for that mu (a run that stops half done).

Grid: x (``n_x`` points, chunks of 4) x y (3 points); outer axes mu (3) x v_throw (2) by default.
"""

from __future__ import annotations

import os
import time

import numpy as np

from rimroll.study.registry import Axis, Study, Var, register


def _axes(s):
    return [Axis("x", np.linspace(0.0, 1.0, s["n_x"]), "1", "probe coordinate x"),
            Axis("y", np.linspace(-1.0, 1.0, 3), "1", "probe coordinate y")]


def _compute(coords, p, s):
    x, y = coords
    if s["delay"]:
        time.sleep(s["delay"])
    fail = os.environ.get("FANOUT_PROBE_FAIL_MU")
    if fail and float(fail) == p.mu:
        raise RuntimeError(f"probe asked to fail at mu={p.mu}")
    if s["log"]:
        fd = os.open(s["log"], os.O_WRONLY | os.O_APPEND | os.O_CREAT, 0o644)
        try:
            os.write(fd, f"{float(p.mu)!r} {float(s['v_throw'])!r} {float(x[0, 0])!r}\n".encode())
        finally:
            os.close(fd)
    return {"f": np.sin(3.0 * x * p.mu) + s["v_throw"] * y + p.rho + p.j,
            "code": ((x + y) > 0.5).astype(np.int8)}


register(Study(
    name="fanout-probe",
    title="Test-only probe of the fan-out (sleep per chunk, log of computed chunks)",
    settings={"mu": (0.5, 1.0, 2.0), "v_throw": (1.0, 2.0), "n_x": 8, "delay": 0.0, "log": ""},
    sweepable=("mu", "v_throw", "j", "rho_over_R", "k_r"),
    axes=_axes,
    variables=[Var("f", "1", "probe value"),
               Var("code", "1", "probe flag", dtype="int8", flag_values=(0, 1), flag_meanings="low high")],
    compute=_compute,
    chunks={"x": 4},
))
