"""rimroll's numerical core: physics of the ball on the rim and its integration.

numpy arrays in, numpy arrays out; no xarray, no dask, no I/O. Three rooms
(docs/architecture.md):

* ``physics``: parameters, the equations of motion and contact forces of each phase,
  kinematics, free flight, the rolling <-> slipping maps;
* ``engine``: the integration of whole grids of initial states into outcomes (methods, stepper,
  events, rules, scene kernels, ``simulate``, backends); imports physics only;
* ``analysis``: steady motions, Floquet analysis, conserved quantities, reduced dynamics,
  solution types, boundaries, predictability, traces and the scipy reference.

The names of :data:`__all__` are the public API. Each is imported on first use (``import
rimroll.solver.physics.params`` does not load the engine, scipy's special functions or numba's
kernels).
"""

import importlib

_PUBLIC = {
    "OUTCOME_MEANINGS": ("rimroll.solver.engine.outcomes", "OUTCOME_MEANINGS"),
    "STATUS_MEANINGS": ("rimroll.solver.engine.outcomes", "STATUS_MEANINGS"),
    "Params": ("rimroll.solver.physics.params", "Params"),
    "floquet": ("rimroll.solver.analysis.floquet", None),
    "invariants": ("rimroll.solver.analysis.invariants", "invariants"),
    "kinematics": ("rimroll.solver.physics.kinematics", None),
    "predictability": ("rimroll.solver.analysis.predictability", None),
    "rolling": ("rimroll.solver.physics.rolling", None),
    "shots": ("rimroll.solver.shots", None),
    "simulate": ("rimroll.solver.engine.simulate", "simulate"),
    "slipping": ("rimroll.solver.physics.slipping", None),
    "steady": ("rimroll.solver.analysis.steady", None),
}

__all__ = sorted(_PUBLIC)


def __getattr__(name: str):
    """A name of the public API, imported on first use; the rooms and modules of the solver as usual."""
    if name in _PUBLIC:
        module, attr = _PUBLIC[name]
        value = importlib.import_module(module)
        value = getattr(value, attr) if attr else value
        globals()[name] = value
        return value
    if name in ("physics", "engine", "analysis"):
        return importlib.import_module(f"rimroll.solver.{name}")
    raise AttributeError(f"module 'rimroll.solver' has no attribute {name!r}")


def __dir__():
    return sorted({*globals(), *__all__, "physics", "engine", "analysis"})
