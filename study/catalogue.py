"""The catalogue of rimroll's own studies: what ``study list``, ``study info NAME`` and ``study run NAME
--help`` say about each one, read from ``catalogue.json`` beside this module rather than from the
studies' modules, whose imports (the solver's kernels, numba, matplotlib) cost 1.5-3 s before a word.

The file holds one card per study (``study.describe.card``: title, summary, variables, the lines of
its settings, what it sweeps, its grids and the run's seconds on one core), made from the studies
themselves by ``python docs/gen_studies.py``; tests/study/test_cli_info.py fails while a card differs from
what its study declares. A study without a card here (a plugin's, one of ``$RIMROLL_STUDY_MODULES``,
one added since the file was made) or whose entry point names another module than its card is
described from its module, as before: the catalogue is never the only source of what it says.
"""

from __future__ import annotations

import functools
import json
import os
import pathlib

from rimroll.study import registry

FILE = pathlib.Path(__file__).with_name("catalogue.json")
OWN_MODULES = "rimroll.workflows."
"""The entry points whose studies the catalogue holds: rimroll's own (another package's are read from it)."""


@functools.lru_cache(maxsize=1)
def stored() -> dict:
    """The cards of ``catalogue.json``, ``{name: {"module": entry point value, "card": card}}``; empty
    when the file is missing or unreadable (every study is then described from its module)."""
    try:
        return json.loads(FILE.read_text(encoding="utf-8"))["studies"]
    except (OSError, ValueError, KeyError, TypeError):
        return {}


def _entry_points() -> dict[str, str]:
    return {ep.name: ep.value for ep in registry.study_entry_points()}


def card(name: str) -> dict | None:
    """The stored card of study ``name`` (``study.describe.render`` makes ``study info NAME`` of it), or
    None when the catalogue has none for it or its entry point now names another module."""
    entry = stored().get(name)
    if entry is None or _entry_points().get(name) != entry["module"]:
        return None
    return entry["card"]


def titles() -> dict[str, str] | None:
    """``{name: title}`` of every study ``study list`` shows, from the catalogue; None when one of them
    has no card there (a plugin study, ``$RIMROLL_STUDY_MODULES``, a study added since): then the studies'
    modules tell."""
    if os.environ.get(registry.PLUGIN_ENV):
        return None
    points = _entry_points()
    cards = stored()
    out = {}
    for name in registry.known_names():
        entry = cards.get(name)
        if entry is None or points.get(name) != entry["module"]:
            return None
        out[name] = entry["card"]["title"]
    return out


def build() -> dict:
    """The catalogue made from the registered studies of rimroll's own entry points (imports them all):
    what ``catalogue.json`` must hold."""
    from rimroll.study.describe import card as card_of

    points = _entry_points()
    names = [n for n in registry.natural_order(registry.names()) if points.get(n, "").startswith(OWN_MODULES)]
    return {name: {"module": points[name], "card": card_of(registry.get(name))} for name in names}


def write(path: pathlib.Path) -> pathlib.Path:
    """Write :func:`build` as JSON to ``path`` (a source checkout's ``study/catalogue.json``; never the
    installed package): one study per block, stable order, so that a change reads as a small diff."""
    text = json.dumps({"about": "made by docs/gen_studies.py from the studies (rimroll.study.catalogue); "
                                "do not edit by hand", "studies": build()}, indent=1, ensure_ascii=False)
    path.write_text(text + "\n", encoding="utf-8")
    return path
