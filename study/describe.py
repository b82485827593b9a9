"""What ``study info NAME`` and ``study run NAME --help`` say about a study before it runs.

What it computes (its title and its module's summary), every setting with its default, its
``--quick`` value, units, meaning and allowed values (``study.setting_table``), which settings
``--set`` can sweep, the grid (dimensions and sizes at the defaults and with ``--quick``) and an
estimate of the run time from the study's ``cost`` (``Study.cost``, seconds per grid point
measured on one core of the development machine; ``cost_scale``, ``compiles``).
"""

from __future__ import annotations

import inspect
import math
import os

from rimroll.study import registry
from rimroll.study.registry import PHYSICAL_KEYS, Study
from rimroll.study.setting_table import FINITE, NUMBER, lookup


def summary(study: Study) -> str:
    """First paragraph of the docstring of the module that defines the study's ``compute``."""
    module = inspect.getmodule(study.compute)
    doc = inspect.getdoc(module) or ""
    return " ".join(doc.split("\n\n")[0].split())


def format_value(value) -> str:
    """A setting's value as ``study info`` and docs/studies.md show it (a swept tuple as a,b,c)."""
    if isinstance(value, tuple):
        return ",".join(f"{v:g}" if isinstance(v, float) else str(v) for v in value)
    if isinstance(value, float):
        return f"{value:g}"
    return str(value)


def settings_lines(study: Study) -> list[str]:
    """One line per setting: name, default, --quick value, [units], meaning (allowed values), all
    from the setting table; physical parameters last, those the study ignores (``Study.ignores``,
    refused by ``--set``) in a final line."""
    from rimroll import solver
    table = {**{k: v for k, v in solver.Params().as_dict().items() if k not in study.settings}, **study.settings}
    keys = [*study.settings, *(k for k in PHYSICAL_KEYS if k not in study.settings and k not in study.ignores)]
    width = max(map(len, keys))
    lines = []
    for key in keys:
        setting = lookup(key)
        text = f"  {key:<{width}}  {format_value(table[key]):>12}"
        text += f"  (--quick {format_value(study.quick[key])})" if key in study.quick else ""
        text += f"  [{setting.units}]" if setting.units else ""
        text += f"  {setting.doc}" if setting.doc else ""
        text += f" ({allowed(setting)})" if allowed(setting) else ""
        if key in study.sweepable:
            text += "  (sweepable)"
        lines.append(text)
    if study.ignores:
        reasons: dict = {}
        for key, why in study.ignores.items():
            reasons.setdefault(why, []).append(key)
        lines += [f"  not used (--set refuses them): {', '.join(keys)}: {why}" for why, keys in reasons.items()]
    return lines


def allowed(setting) -> str:
    """What a setting allows, as ``study info`` shows it: "" for a free label and for any finite
    number (of bounded magnitude or not)."""
    if setting.choices is None and setting.range in (None, NUMBER, FINITE):
        return ""
    return setting.allowed(units=False)


def _grid(study: Study, quick: bool) -> tuple[str, int, int]:
    from rimroll.study.plan import make_plan

    plan = make_plan(study, quick)
    dims = " x ".join(f"{a.name} {a.values.size}" for a in plan.axes)
    return dims, math.prod(plan.shape), plan.n_chunks


def estimate(study: Study, points: int, workers: int, quick: bool = False) -> str:
    """Rough run time for ``points`` grid points on ``workers`` busy threads (at most one per
    chunk), from the study's ``cost`` per point, scaled by its ``cost_scale`` setting (plus a few
    seconds of start-up and writing, not counted)."""
    seconds = study.core_seconds(points, {**study.settings, **(study.quick if quick else {})})
    return estimate_text(seconds, workers, study.compiles)


def estimate_text(core_seconds: float | None, workers: int, compiles: bool) -> str:
    """The run time ``study info`` states for ``core_seconds`` of work on one core (None: the study has
    no cost model) shared by ``workers`` busy threads; ``compiles``: the first run of an install also
    compiles the simulation kernels."""
    if core_seconds is None:
        return "no estimate for this study"
    seconds = core_seconds / max(workers, 1)
    text = f"about {seconds:.0f} s" if seconds >= 1 else "under a second"
    if compiles:
        text += (" (the first run of an install also compiles its simulation kernels, once: announced, with the time "
                 "their last compile took on this machine)")
    return text


def card(study: Study) -> dict:
    """Everything ``study list``, ``study info NAME`` and ``study run NAME --help`` say about ``study``,
    as plain JSON values: its title and summary, variables, the lines of its settings, what it sweeps,
    and per grid (default, ``--quick``) the dimensions, points, chunks and the run's seconds on one core
    (``Study.core_seconds``; None without a cost model). ``study.catalogue`` stores the cards of
    rimroll's own studies, so that these commands need not import the studies' modules."""
    grids = []
    for quick in (False, True):
        dims, points, chunks = _grid(study, quick)
        seconds = study.core_seconds(points, {**study.settings, **(study.quick if quick else {})})
        grids.append({"dims": dims, "points": int(points), "chunks": int(chunks),
                      "core_seconds": None if seconds is None else float(seconds)})
    derived = [[name if isinstance(name, str) else ", ".join(name), units] for name, units, _ in study.derived_docs]
    return {"name": study.name, "title": study.title, "summary": summary(study),
            "variables": [[v.name, v.units] for v in study.variables], "derived": derived,
            "settings": settings_lines(study), "sweepable": list(study.sweepable), "grids": grids,
            "compiles": bool(study.compiles)}


def describe(name: str) -> list[str]:
    """The lines of ``study info NAME``."""
    return render(card(registry.get(name)))


def render(card: dict, workers: int | None = None) -> list[str]:
    """The lines of ``study info NAME`` from the study's ``card``; the run times on ``workers`` cores
    (default: this machine's)."""
    workers = workers or os.cpu_count() or 1
    lines = [f"{card['name']}: {card['title']}"]
    if card["summary"]:
        lines.append(f"  {card['summary']}")
    lines.append("variables: " + ", ".join(f"{name} [{units}]" for name, units in card["variables"]))
    if card["derived"]:
        lines.append("derived from the whole grid once it is computed: "
                     + ", ".join(f"{name} [{units}]" for name, units in card["derived"]))
    lines.append("settings (default, --quick, units; change with --set KEY=VALUE):")
    lines += card["settings"]
    sweepable = ", ".join(card["sweepable"]) or "none"
    lines.append(f"sweepable (--set KEY=a,b,c or KEY=start:stop:num makes an axis): {sweepable}; "
                 "a grid axis takes a list or range too (new grid values)")
    for label, grid in zip(("grid", "grid with --quick"), card["grids"]):
        time = estimate_text(grid["core_seconds"], min(workers, grid["chunks"]), card["compiles"])
        lines.append(f"{label}: {grid['dims']} = {grid['points']} points in {grid['chunks']} chunks; "
                     f"run time on {workers} cores: {time}")
    lines.append(f"run: study run {card['name']} [--quick] [--set KEY=VALUE ...] [--out DIR]; "
                 "output: <out>/" + card["name"] + ".nc and .png")
    return lines
