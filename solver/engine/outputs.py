"""The output variables of ``simulate``, declared once: name, dtype, units, long_name, comment and the
tolerance a regression check allows.

Everything that handles an output reads it from :data:`OUTPUTS`: the result columns of the scene
kernels (:data:`FLOAT_COLUMNS`, :data:`INT_COLUMNS`: a kernel writes ``float_results[column("t_end")]``),
``simulate``'s result dict, the variables of every study that stores them
(``rimroll.study.registry.output_var``) and ``study verify``'s comparison. Adding an output means one
entry here and the line of the kernel that writes it.

``tolerance`` is the (atol, rtol) of a continuous output when a result at a study's default
precision is compared with a reference slice computed at rtol = 1e-12 with DOP853 (``None``: the
default of the comparison; a categorical output is compared for identity). ``compared=False``:
integrator work, different by design between precisions.
"""

from __future__ import annotations

import dataclasses

from rimroll.solver.engine import outcomes


@dataclasses.dataclass(frozen=True)
class Output:
    """One output of ``simulate``; ``in_kernel``: a column the kernels write (else derived after the run)."""

    name: str
    dtype: str
    units: str
    long_name: str
    comment: str = ""
    tolerance: tuple | None = None
    meanings: dict | None = None  # categorical: code -> "label: meaning"
    standard_name: str | None = None
    in_kernel: bool = True
    compared: bool = True

    @property
    def flag_values(self) -> tuple | None:
        return None if self.meanings is None else tuple(self.meanings)

    @property
    def flag_meanings(self) -> str | None:
        return None if self.meanings is None else outcomes.flag_meanings(self.meanings)


OUTPUTS = (
    # float64 result columns of the kernels, in column order
    Output("t_end", "float64", "s", "time the run ended", "separation from the rim, detection of periodic rolling "
           "(the second transversal omega1 zero), or t_max", tolerance=(1e-3, 1e-3)),
    Output("f2_min", "float64", "N", "smallest normal force F2 along the run", "(31) while rolling, (41) while "
           "slipping; a deadlock boundary is where it reaches 0", tolerance=(1e-3, 1e-3)),
    Output("half_period", "float64", "s", "half period of periodic rolling", "t2 - t1 between the two transversal "
           "omega1 zeros (Prop. 4); NaN unless periodic", tolerance=(1e-4, 1e-4)),
    Output("revolutions", "float64", "1", "revolutions around the rim", "angle alpha travelled (19) / 2 pi, signed",
           tolerance=(1e-3, 1e-3)),
    Output("slip_time", "float64", "s", "time spent slipping", "summed over the slip phases (Sect. 5.2)",
           tolerance=(1e-3, 1e-2)),
    Output("energy_drift", "float64", "1", "relative change of the mechanical energy",
           "|E(t_end) - E(0)| / max(|E(0)|, m g rho), E of (60) with m g rho sin(beta): the integration drift in "
           "conservative rolling, the energy lost otherwise", tolerance=(1e-5, 1e-2)),
    Output("beta_end", "float64", "rad", "height angle at t_end", "before any free flight",
           tolerance=(1e-3, 1e-3)),
    Output("omega1_end", "float64", "s-1", "transversal angular velocity at t_end", "before any free flight",
           tolerance=(1e-2, 1e-3)),
    Output("omega2_end", "float64", "s-1", "orthogonal angular velocity at t_end", "before any free flight",
           tolerance=(1e-2, 1e-3)),
    Output("omega3_end", "float64", "s-1", "circular angular velocity at t_end", "before any free flight",
           tolerance=(1e-2, 1e-3)),
    Output("u1_end", "float64", "m s-1", "slip velocity u1 of the contact point at t_end", "along n1 (Sect. 5.2); "
           "0 when rolling at t_end; before any free flight", tolerance=(1e-3, 1e-3)),
    Output("u3_end", "float64", "m s-1", "slip velocity u3 of the contact point at t_end", "along n3 (Sect. 5.2); "
           "0 when rolling at t_end; before any free flight", tolerance=(1e-3, 1e-3)),
    # int64 result columns of the kernels, in column order (stored as dtype)
    Output("outcome", "int8", "1", "outcome of the ball on the rim", "rules: docs/outcome-engine.md",
           meanings=outcomes.OUTCOME_MEANINGS),
    Output("slip_phases", "int32", "1", "number of slip phases"),
    Output("n_steps", "int64", "1", "attempted integrator steps", compared=False),
    Output("status", "int8", "1", "integration status", "ok unless the run stopped early",
           meanings=outcomes.STATUS_MEANINGS, standard_name="status_flag"),
    Output("n_searched", "int64", "1", "accepted steps whose dense output was searched for events",
           "the cost of the grazing check (docs/outcome-engine.md)", compared=False),
    Output("n_slip_steps", "int64", "1", "attempted steps of slip phases", compared=False),
    # derived after the run
    Output("steady_h", "float64", "s-2", "h of (54) of a steady motion", "for outcome steady_motion: < 0 stable, "
           "> 0 unstable; NaN otherwise", in_kernel=False),
    Output("on_rim_reason", "int8", "1", "why the ball is still on the rim when the run stopped",
           "from outcome, status and slip_phases", meanings=outcomes.ON_RIM_REASON_MEANINGS, in_kernel=False),
)
BY_NAME = {o.name: o for o in OUTPUTS}
FLOAT_COLUMNS = tuple(o.name for o in OUTPUTS if o.in_kernel and o.dtype == "float64")
"""The float64 result columns of the kernels (``float_results``), by name in column order."""
INT_COLUMNS = tuple(o.name for o in OUTPUTS if o.in_kernel and o.dtype != "float64")
"""The int64 result columns of the kernels (``int_results``), by name in column order."""


def column(name: str) -> int:
    """The result column of a kernel output (in ``float_results`` for float64 outputs, else ``int_results``)."""
    columns = FLOAT_COLUMNS if BY_NAME[name].dtype == "float64" else INT_COLUMNS
    return columns.index(name)


def output(name: str) -> Output:
    """The output called ``name``; ValueError listing the outputs otherwise."""
    try:
        return BY_NAME[name]
    except KeyError:
        raise ValueError(f"unknown output {name!r} of simulate; outputs: {', '.join(BY_NAME)}") from None
