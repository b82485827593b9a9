"""rimroll's numerical core: physics of the ball on the rim and its integration.

numpy arrays in, numpy arrays out; no xarray, no dask, no I/O.
"""

from solver.params import Params
from solver import kinematics, rolling, slipping, steady
from solver import floquet
from solver.invariants import invariants

__all__ = ["Params", "kinematics", "rolling", "slipping", "steady"]
__all__ += ["floquet", "invariants"]
from solver.outcomes import OUTCOME_MEANINGS, STATUS_MEANINGS
from solver.simulate import simulate
from solver import predictability

__all__ += ["simulate", "OUTCOME_MEANINGS", "STATUS_MEANINGS", "predictability"]
