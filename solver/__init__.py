"""rimroll's numerical core: physics of the ball on the rim and its integration.

numpy arrays in, numpy arrays out; no xarray, no dask, no I/O. Three rooms
(docs/architecture.md):

* ``physics``: parameters, the equations of motion and contact forces of each phase,
  kinematics, free flight, the rolling <-> slipping maps;
* ``engine``: the integration of whole grids of initial states into outcomes (methods, stepper,
  events, rules, scene kernels, ``simulate``, backends); imports physics only;
* ``analysis``: steady motions, Floquet analysis, conserved quantities, reduced dynamics,
  solution types, boundaries, predictability, traces and the scipy reference.

The names below are the public API.
"""

from rimroll.solver.analysis import floquet, predictability, steady
from rimroll.solver.analysis.invariants import invariants
from rimroll.solver.engine.outcomes import OUTCOME_MEANINGS, STATUS_MEANINGS
from rimroll.solver.engine.simulate import simulate
from rimroll.solver.physics import kinematics, rolling, slipping
from rimroll.solver.physics.params import Params

__all__ = [
    "OUTCOME_MEANINGS",
    "STATUS_MEANINGS",
    "Params",
    "floquet",
    "invariants",
    "kinematics",
    "predictability",
    "rolling",
    "simulate",
    "slipping",
    "steady",
]
