"""rimroll's named studies, one module per family; importing this package registers them all."""

from workflows import steady_maps  # noqa: F401
from workflows import global_dynamics  # noqa: F401
from workflows import outcome_grids  # noqa: F401
from workflows import cubes  # noqa: F401
from workflows import work_precision  # noqa: F401
from workflows import predictability  # noqa: F401
