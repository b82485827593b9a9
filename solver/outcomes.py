"""Outcome and status codes of ``solver.simulate`` (int8), with their one-line meanings."""

from __future__ import annotations

FALL_IN = 0
FALL_OUT = 1
PERIODIC_ROLLING = 2
ON_RIM_AT_T_MAX = 3
STEADY_MOTION = 4

OUTCOME_MEANINGS = {
    FALL_IN: "fall_in: the ball left the rim and its centre came down inside the rim (a score)",
    FALL_OUT: "fall_out: the ball left the rim and its centre came down outside the rim",
    PERIODIC_ROLLING: "periodic_rolling: omega1 vanished twice in one rolling stretch; the orbit repeats forever (61)",
    ON_RIM_AT_T_MAX: "on_rim_at_t_max: still on the rim when the run stopped (at t_max, or earlier if status != 0)",
    STEADY_MOTION: "steady_motion: the initial state is a steady motion (47)-(48) or (46) to within the tolerance; "
                   "it never moves (steady_h of (54): < 0 stable, > 0 unstable)",
}
OUTCOME_FLAG_VALUES = tuple(OUTCOME_MEANINGS)
OUTCOME_FLAG_MEANINGS = " ".join(m.split(":")[0] for m in OUTCOME_MEANINGS.values())

OK = 0
MAX_STEPS = 1
STEP_SIZE_UNDERFLOW = 2
NON_FINITE = 3
TOO_MANY_SWITCHES = 4

STATUS_MEANINGS = {
    OK: "ok: the run ended by its rules (fall, periodic orbit or t_max)",
    MAX_STEPS: "max_steps: the step budget ran out before t_max; raise max_steps or loosen rtol",
    STEP_SIZE_UNDERFLOW: "step_size_underflow: the step fell below 10 ulps of t; the state is near a singularity",
    NON_FINITE: "non_finite: the state or its rates became inf/NaN; check the initial state's magnitude",
    TOO_MANY_SWITCHES: "too_many_switches: more rolling/slipping switches than max_switches (chattering); raise it",
}
STATUS_FLAG_VALUES = tuple(STATUS_MEANINGS)
STATUS_FLAG_MEANINGS = " ".join(m.split(":")[0] for m in STATUS_MEANINGS.values())
