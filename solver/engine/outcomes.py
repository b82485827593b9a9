"""Outcome, status and on-the-rim codes of ``solver.simulate`` (int8), with their one-line meanings."""

from __future__ import annotations

import numpy as np

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
STIFF_SLIP = 5

STATUS_MEANINGS = {
    OK: "ok: the run ended by its rules (fall, periodic orbit or t_max)",
    MAX_STEPS: "max_steps: the step budget ran out before t_max; raise max_steps or loosen rtol",
    STEP_SIZE_UNDERFLOW: "step_size_underflow: the step fell below 10 ulps of t; the state is near a singularity",
    NON_FINITE: "non_finite: the state or its rates became inf/NaN; check the initial state's magnitude",
    TOO_MANY_SWITCHES: "too_many_switches: more rolling/slipping switches than max_switches (chattering); raise it",
    STIFF_SLIP: "stiff_slip: the step budget ran out, at least half of it in slip phases whose slip speed stays near "
                "delta, where the slipping equations (42) are stiff (steps at the explicit stability limit, ~6000 per "
                "slip of a few ms); the slips come at a steady rate, not a Zeno accumulation; raise max_steps",
}
STATUS_FLAG_VALUES = tuple(STATUS_MEANINGS)
STATUS_FLAG_MEANINGS = " ".join(m.split(":")[0] for m in STATUS_MEANINGS.values())

NOT_ON_RIM = 0
ROLLING_TRANSIENT = 1
SLIP_ROLL_CYCLING = 2
ONE_SLIP = 3
STOPPED_EARLY = 4

ON_RIM_REASON_MEANINGS = {
    NOT_ON_RIM: "not_on_rim: the run ended by a fall, a periodic orbit or a steady motion",
    ROLLING_TRANSIENT: "rolling_transient: rolled to t_max without a slip and closed no periodic orbit (a long "
                       "transient: a half period beyond the time left, near a separatrix, or a dissipative decay)",
    SLIP_ROLL_CYCLING: "slip_roll_cycling: slipped and rolled again two or more times (slip_phases) and was still "
                       "on the rim at t_max",
    ONE_SLIP: "one_slip: one slip phase, still slipping at t_max or rolling after it without closing an orbit",
    STOPPED_EARLY: "stopped_early: the run stopped before t_max (status says why: max_steps, stiff_slip, ...)",
}
ON_RIM_REASON_FLAG_VALUES = tuple(ON_RIM_REASON_MEANINGS)
ON_RIM_REASON_FLAG_MEANINGS = " ".join(m.split(":")[0] for m in ON_RIM_REASON_MEANINGS.values())


def on_rim_reason(outcome, status, slip_phases) -> np.ndarray:
    """Why each run ended on the rim (int8 codes of :data:`ON_RIM_REASON_MEANINGS`).

    Read off the run's ``outcome``, ``status`` and ``slip_phases`` (arrays of one shape, as
    ``solver.simulate`` returns them); ``not_on_rim`` where the outcome is not ``on_rim_at_t_max``.
    """
    outcome, status, slips = np.asarray(outcome), np.asarray(status), np.asarray(slip_phases)
    reason = np.select([status != OK, slips >= 2, slips == 1], [STOPPED_EARLY, SLIP_ROLL_CYCLING, ONE_SLIP],
                       ROLLING_TRANSIENT)
    return np.where(outcome == ON_RIM_AT_T_MAX, reason, NOT_ON_RIM).astype(np.int8)
