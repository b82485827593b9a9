"""rimroll's study layer: named studies, dask fan-out, netCDF results, plots, the ``study`` CLI.

All file I/O of rimroll lives here; ``solver`` stays pure numpy.
"""

from rimroll.study.registry import Axis, Study, UserError, Var, get, register

__all__ = ["Axis", "Study", "UserError", "Var", "get", "register"]
