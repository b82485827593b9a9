"""The event-driven loop of shots: flights, contact times, impacts, the end of each shot."""

from __future__ import annotations


def run_shots(releases: dict, params, contact, budget: tuple[float, int], trace=False) -> dict:
    """The outputs of ``shots.simulate_shots`` (or, with ``trace``, of ``shots.trace_shot``)."""
    raise NotImplementedError("the shot loop is being written")
