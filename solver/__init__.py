"""rimroll's numerical core: physics of the ball on the rim and its integration.

numpy arrays in, numpy arrays out; no xarray, no dask, no I/O. Three subpackages
(docs/architecture.md):

* ``physics``: parameters, the equations of motion and contact forces of each phase,
  kinematics, free flight, the rolling <-> slipping maps;
* ``engine``: the integration of whole grids of initial states into outcomes (methods, stepper,
  events, rules, scene kernels, ``simulate``, backends); imports physics only;
* ``shots``: a shot from the release through flight, rim and board impacts and capture onto the rim;
* ``analysis``: steady motions, Floquet analysis, conserved quantities, reduced dynamics,
  solution types, boundaries, predictability, traces and the scipy reference.

The names of ``__all__`` are the public API. Each is imported on first use (``import
rimroll.solver.physics.params`` does not load the engine, scipy's special functions or numba's
kernels).
"""

import importlib
from typing import TYPE_CHECKING

if TYPE_CHECKING:  # the public names for type checkers and the API reference; at run time each loads on first use
    from rimroll.solver import shots
    from rimroll.solver.analysis import floquet, predictability, steady
    from rimroll.solver.analysis.invariants import invariants
    from rimroll.solver.engine.outcomes import OUTCOME_MEANINGS, STATUS_MEANINGS
    from rimroll.solver.engine.simulate import simulate
    from rimroll.solver.physics import kinematics, rolling, slipping
    from rimroll.solver.physics.params import Params

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

# literal, so that tools that read the source without importing it (mkdocstrings) see the public names;
# tests/docs/test_docs_blocks.py checks that it names exactly the keys of _PUBLIC
__all__ = ["OUTCOME_MEANINGS", "Params", "STATUS_MEANINGS", "floquet", "invariants", "kinematics", "predictability",
           "rolling", "shots", "simulate", "slipping", "steady"]


def __getattr__(name: str):
    """A name of the public API, imported on first use; the subpackages and modules of the solver as usual."""
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
