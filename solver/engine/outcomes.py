"""Outcome, status and on-the-rim codes of ``solver.simulate`` (int8), with their one-line meanings.

Every code table of the solver (these three, ``solver.analysis.solution_types``,
``solver.analysis.boundaries``) is built by :func:`code_table` from its text, one ``name: meaning`` a line;
the codes are the lines' order.
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


def code_table(text: str) -> CodeTable:
    """The :class:`CodeTable` of a table written one entry a line, ``name: meaning``, coded 0, 1, 2, ... in
    order (an indented line continues the entry above it). Names are distinct words, as CF flag_meanings needs
    them; raises ValueError naming an entry that is not of that form."""
    entries = []
    for line in text.strip("\n").splitlines():
        if line[:1].isspace() and entries:
            entries[-1] += " " + line.strip()
        elif line.strip():
            entries.append(line.strip())
    meanings = dict(enumerate(entries))
    names = [m.split(":")[0] for m in entries]
    for meaning, name in zip(entries, names):
        if ":" not in meaning or not name.isidentifier():
            raise ValueError(f"code table entry {meaning!r}: expected 'name: meaning' with a one-word name")
    if len(set(names)) != len(names):
        raise ValueError(f"code table names repeat: {names}")
    return CodeTable(meanings, tuple(meanings), " ".join(names))


OUTCOMES = code_table("""
fall_in: the ball left the rim and its centre came down inside the rim (a score)
fall_out: the ball left the rim and its centre came down outside the rim
periodic_rolling: omega1 vanished twice in one rolling stretch; the orbit repeats forever (61)
on_rim_at_t_max: still on the rim when the run stopped (at t_max, or earlier if status != 0)
steady_motion: the initial state is a steady motion (47)-(48) or (46) to within the tolerance; it never moves
    (steady_h of (54): < 0 stable, > 0 unstable)
""")
OUTCOME_MEANINGS, OUTCOME_FLAG_VALUES, OUTCOME_FLAG_MEANINGS = OUTCOMES
FALL_IN, FALL_OUT, PERIODIC_ROLLING, ON_RIM_AT_T_MAX, STEADY_MOTION = OUTCOME_FLAG_VALUES


STATUSES = code_table("""
ok: the run ended by its rules (fall, periodic orbit or t_max)
max_steps: the step budget ran out before t_max; raise max_steps or loosen rtol
step_size_underflow: the step fell below 10 ulps of t; the state is near a singularity
non_finite: the state or its rates became inf/NaN; check the initial state's magnitude
too_many_switches: more rolling/slipping switches than max_switches (chattering); raise it
stiff_slip: the step budget ran out, at least half of it in slip phases whose slip speed stays near delta, where the
    slipping equations (42) are stiff (steps at the explicit stability limit, ~6000 per slip of a few ms); the slips
    come at a steady rate, not a Zeno accumulation; raise max_steps
""")
STATUS_MEANINGS, STATUS_FLAG_VALUES, STATUS_FLAG_MEANINGS = STATUSES
OK, MAX_STEPS, STEP_SIZE_UNDERFLOW, NON_FINITE, TOO_MANY_SWITCHES, STIFF_SLIP = STATUS_FLAG_VALUES


ON_RIM_REASONS = code_table("""
not_on_rim: the run ended by a fall, a periodic orbit or a steady motion
rolling_transient: rolled to t_max without a slip and closed no periodic orbit (a long transient: a half period
    beyond the time left, near a separatrix, or a dissipative decay)
slip_roll_cycling: slipped and rolled again two or more times (slip_phases) and was still on the rim at t_max
one_slip: one slip phase, still slipping at t_max or rolling after it without closing an orbit
stopped_early: the run stopped before t_max (status says why: max_steps, stiff_slip, ...)
""")
ON_RIM_REASON_MEANINGS, ON_RIM_REASON_FLAG_VALUES, ON_RIM_REASON_FLAG_MEANINGS = ON_RIM_REASONS
NOT_ON_RIM, ROLLING_TRANSIENT, SLIP_ROLL_CYCLING, ONE_SLIP, STOPPED_EARLY = ON_RIM_REASON_FLAG_VALUES


def on_rim_reason(outcome, status, slip_phases) -> np.ndarray:
    """Why each run ended on the rim (int8 codes of :data:`ON_RIM_REASON_MEANINGS`).

    Read off the run's ``outcome``, ``status`` and ``slip_phases`` (arrays of one shape, as
    ``solver.simulate`` returns them); ``not_on_rim`` where the outcome is not ``on_rim_at_t_max``.
    """
    outcome, status, slips = np.asarray(outcome), np.asarray(status), np.asarray(slip_phases)
    reason = np.select([status != OK, slips >= 2, slips == 1], [STOPPED_EARLY, SLIP_ROLL_CYCLING, ONE_SLIP],
                       ROLLING_TRANSIENT)
    return np.where(outcome == ON_RIM_AT_T_MAX, reason, NOT_ON_RIM).astype(np.int8)
