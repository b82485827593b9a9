"""Outcome, status and on-the-rim codes of ``solver.simulate`` (int8), with their one-line meanings.

Every code table of the solver (these three, ``solver.analysis.solution_types``,
``solver.analysis.boundaries``) is built by :func:`code_table` from ``{code: "name: meaning"}``.
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np


class CodeTable(NamedTuple):
    """A categorical variable's codes: ``meanings`` {code: "name: one-line meaning"}, and the CF attributes
    ``flag_values`` (the codes, in table order) and ``flag_meanings`` (the names, blank-separated)."""

    meanings: dict
    flag_values: tuple
    flag_meanings: str


def flag_meanings(meanings: dict) -> str:
    """The CF ``flag_meanings`` of ``{code: "name: meaning"}``: the names before the colons, blank-separated."""
    return " ".join(m.split(":")[0] for m in meanings.values())


def code_table(meanings: dict) -> CodeTable:
    """The :class:`CodeTable` of ``{code: "name: meaning"}`` (codes: distinct ints; names: distinct words,
    as CF flag_meanings needs them). Raises ValueError naming an entry that is not of that form."""
    names = [m.split(":")[0] for m in meanings.values()]
    for (code, meaning), name in zip(meanings.items(), names):
        if not isinstance(code, int) or ":" not in meaning or not name.isidentifier():
            raise ValueError(f"code table entry {code!r}: {meaning!r}; expected an int code and 'name: meaning' "
                             f"with a one-word name")
    if len(set(names)) != len(names):
        raise ValueError(f"code table names repeat: {names}")
    return CodeTable(dict(meanings), tuple(meanings), " ".join(names))

FALL_IN = 0
FALL_OUT = 1
PERIODIC_ROLLING = 2
ON_RIM_AT_T_MAX = 3
STEADY_MOTION = 4

OUTCOME_MEANINGS, OUTCOME_FLAG_VALUES, OUTCOME_FLAG_MEANINGS = code_table({
    FALL_IN: "fall_in: the ball left the rim and its centre came down inside the rim (a score)",
    FALL_OUT: "fall_out: the ball left the rim and its centre came down outside the rim",
    PERIODIC_ROLLING: "periodic_rolling: omega1 vanished twice in one rolling stretch; the orbit repeats forever (61)",
    ON_RIM_AT_T_MAX: "on_rim_at_t_max: still on the rim when the run stopped (at t_max, or earlier if status != 0)",
    STEADY_MOTION: "steady_motion: the initial state is a steady motion (47)-(48) or (46) to within the tolerance; "
                   "it never moves (steady_h of (54): < 0 stable, > 0 unstable)",
})

OK = 0
MAX_STEPS = 1
STEP_SIZE_UNDERFLOW = 2
NON_FINITE = 3
TOO_MANY_SWITCHES = 4
STIFF_SLIP = 5

STATUS_MEANINGS, STATUS_FLAG_VALUES, STATUS_FLAG_MEANINGS = code_table({
    OK: "ok: the run ended by its rules (fall, periodic orbit or t_max)",
    MAX_STEPS: "max_steps: the step budget ran out before t_max; raise max_steps or loosen rtol",
    STEP_SIZE_UNDERFLOW: "step_size_underflow: the step fell below 10 ulps of t; the state is near a singularity",
    NON_FINITE: "non_finite: the state or its rates became inf/NaN; check the initial state's magnitude",
    TOO_MANY_SWITCHES: "too_many_switches: more rolling/slipping switches than max_switches (chattering); raise it",
    STIFF_SLIP: "stiff_slip: the step budget ran out, at least half of it in slip phases whose slip speed stays near "
                "delta, where the slipping equations (42) are stiff (steps at the explicit stability limit, ~6000 per "
                "slip of a few ms); the slips come at a steady rate, not a Zeno accumulation; raise max_steps",
})

NOT_ON_RIM = 0
ROLLING_TRANSIENT = 1
SLIP_ROLL_CYCLING = 2
ONE_SLIP = 3
STOPPED_EARLY = 4

ON_RIM_REASON_MEANINGS, ON_RIM_REASON_FLAG_VALUES, ON_RIM_REASON_FLAG_MEANINGS = code_table({
    NOT_ON_RIM: "not_on_rim: the run ended by a fall, a periodic orbit or a steady motion",
    ROLLING_TRANSIENT: "rolling_transient: rolled to t_max without a slip and closed no periodic orbit (a long "
                       "transient: a half period beyond the time left, near a separatrix, or a dissipative decay)",
    SLIP_ROLL_CYCLING: "slip_roll_cycling: slipped and rolled again two or more times (slip_phases) and was still "
                       "on the rim at t_max",
    ONE_SLIP: "one_slip: one slip phase, still slipping at t_max or rolling after it without closing an orbit",
    STOPPED_EARLY: "stopped_early: the run stopped before t_max (status says why: max_steps, stiff_slip, ...)",
})


def on_rim_reason(outcome, status, slip_phases) -> np.ndarray:
    """Why each run ended on the rim (int8 codes of :data:`ON_RIM_REASON_MEANINGS`).

    Read off the run's ``outcome``, ``status`` and ``slip_phases`` (arrays of one shape, as
    ``solver.simulate`` returns them); ``not_on_rim`` where the outcome is not ``on_rim_at_t_max``.
    """
    outcome, status, slips = np.asarray(outcome), np.asarray(status), np.asarray(slip_phases)
    reason = np.select([status != OK, slips >= 2, slips == 1], [STOPPED_EARLY, SLIP_ROLL_CYCLING, ONE_SLIP],
                       ROLLING_TRANSIENT)
    return np.where(outcome == ON_RIM_AT_T_MAX, reason, NOT_ON_RIM).astype(np.int8)
