"""Cold compile of one engine in this (fresh) process with an empty cache; prints one JSON line.

    python benchmarks/peers_cold.py heyoka TOL      # heyoka's batch integrator of the rolling scene at tol
    python benchmarks/peers_cold.py rimroll METHOD  # rimroll's first simulate of the rolling-only scene

heyoka's disk cache is pointed at an empty temporary folder (``llvm_state.set_diskcache_path``), rimroll's
kernel cache too (``RIMROLL_CACHE_DIR``, set before rimroll is imported). Times are CPU seconds of this
process (``time.process_time``), and wall seconds; the import is timed apart from the compile.
"""

from __future__ import annotations

import json
import os
import sys
import tempfile
import time


def _timed(func):
    cpu, wall = time.process_time(), time.perf_counter()
    value = func()
    return value, round(time.process_time() - cpu, 3), round(time.perf_counter() - wall, 3)


def heyoka_cold(tol: float, cache: str) -> dict:
    hy, import_cpu, _ = _timed(lambda: __import__("heyoka"))
    hy.llvm_state.set_diskcache_path(cache)
    from rimroll import solver
    from rimroll.peer_models import heyoka_rolling

    params = solver.Params(mu=float("inf"))
    integrator, cpu, wall = _timed(lambda: heyoka_rolling.Integrator(params, tol))
    return {"engine": "heyoka", "setting": f"tol {tol:g}", "order": integrator.order, "batch": integrator.batch,
            "import_cpu_s": import_cpu, "compile_cpu_s": cpu, "compile_wall_s": wall}


def rimroll_cold(method: str, cache: str) -> dict:
    os.environ["RIMROLL_CACHE_DIR"] = cache
    solver, import_cpu, _ = _timed(lambda: __import__("rimroll.solver", fromlist=["simulate"]))
    import numpy as np

    states = np.array([[1.2, 5.0, 35.0, 10.0], [1.0, -3.0, 35.0, 10.0]])
    params = solver.Params(mu=float("inf"))
    _, cpu, wall = _timed(lambda: solver.simulate(states, params, rtol=1e-8, atol=1e-10, method=method, workers=1))
    return {"engine": "rimroll", "setting": method, "import_cpu_s": import_cpu, "compile_cpu_s": cpu,
            "compile_wall_s": wall}


def main(argv) -> int:
    engine, setting = argv
    with tempfile.TemporaryDirectory(prefix="peers-cold-") as cache:
        row = heyoka_cold(float(setting), cache) if engine == "heyoka" else rimroll_cold(setting, cache)
    print(json.dumps(row))
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
