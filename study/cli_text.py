"""The command line's text read once into Python values: ``KEY=VALUE`` words (``--set``, ``--select``,
``--at``), numbers, and the ``--set`` values of a run (:func:`setting_values`).

One rule serves both meanings of a comma: a word is split on commas, and a piece without ``=``
continues the value of the pair before it. So ``mu=0.5,1,2`` is one key with the list value
``0.5,1,2`` (``--set``), while ``omega1=0.5,beta=1.2`` is two pairs (``--at``, ``--select``).
Keys and values are stripped of surrounding blanks; a word whose first piece has no ``=``, or
that gives an empty key or an empty value, is a one-line :class:`~rimroll.study.registry.UserError`
naming the option, the word and the form expected. What a value means (a number, a list, a
label) is left to the caller; for ``--set`` it is :func:`setting_values`, which hands
``study.plan.make_plan`` the values a Python caller would give (``rimroll.run(mu=(0.5, 1, 2))``):
past this module no setting is text.
"""

from __future__ import annotations

import math

import numpy as np

from rimroll.study.registry import UserError
from rimroll.study.setting_table import MAX_AXIS, lookup
from rimroll.study.settings import default_settings


def split(word: str, option: str, form: str = "KEY=VALUE", example: str = "") -> list[tuple[str, str]]:
    """The ``(key, value)`` pairs of one ``word`` given to ``option`` (e.g. ``"--set"``), in order.

    ``form`` and ``example`` say in an error message what was expected, e.g. ``"DIM=VALUE"`` and
    ``"--select j=0.5"``."""
    pairs: list[tuple[str, list[str]]] = []  # each value's items, joined once at the end (linear in the word)
    for piece in word.split(","):
        key, sep, value = piece.partition("=")
        if sep:
            pairs.append((key.strip(), [value.strip()]))
        elif pairs:
            pairs[-1][1].append(piece.strip())  # a further item of the previous value's list
        else:
            pairs.append(("", [""]))  # no '=' before the first comma: malformed
    joined = [(key, ",".join(items)) for key, items in pairs]
    if not joined or any(not key or not value for key, value in joined):
        hint = f", e.g. {example}" if example else ""
        shown = word if len(word) <= 200 else f"{word[:200]}... ({len(word)} characters)"
        raise UserError(f"malformed {option} {shown!r}: expected {form}{hint}")
    return joined


def parse(words, option: str, form: str = "KEY=VALUE", example: str = "") -> list[tuple[str, str]]:
    """The ``(key, value)`` pairs of every word of a repeatable option, in the order given."""
    return [pair for word in words for pair in split(word, option, form, example)]


# ------------------------------------------------------------------ text -> values, once


def _plain(text: str) -> str:
    """``text`` if it is written in plain ASCII without '_' (Python's float() and int() also read
    full-width digits, '１', and digit groups, '1_0', which a setting should not take for 1 and 10);
    else ValueError."""
    if not text.isascii() or "_" in text:
        raise ValueError(text)
    return text


def number(text: str) -> float:
    """A number the user wrote (a setting, an option, a state): ``float`` of plain ASCII without '_'
    ('inf', '1e-3', '-2' are numbers; '１' and '1_0' are not); ValueError otherwise. Its name is the
    word argparse uses: "invalid number value"."""
    return float(_plain(text))


def integer(text: str) -> int:
    """A whole number the user wrote, as :func:`number`: "invalid integer value" for argparse."""
    return int(_plain(text))


def setting_values(study, words, option: str = "--set") -> dict:
    """The ``--set KEY=TEXT`` words of a run of ``study`` read once into Python values, ``{key: value}``
    in the order given, for ``study.plan.make_plan``: ``KEY=0.5`` a scalar of the type of the setting's
    default (a number, an integer, true/false, a label), ``KEY=a,b,c`` a tuple (labels for a setting of
    labels, else numbers), ``KEY=start:stop:num`` the tuple of an inclusive linspace (``num >= 2``).
    What the values may be (sweepable, in range, a grid axis) is ``study.settings``' to say; a key given
    twice, a malformed word or a text that is no value of its kind is a one-line UserError here."""
    pairs = parse(words, option, "KEY=VALUE", f"{option} mu=0.5")
    given = [key for key, _ in pairs]
    twice = sorted({key for key in given if given.count(key) > 1})
    if twice:  # the later one would silently win: say which value is meant
        key = twice[0]
        sweep = f" (a list sweeps it: {option} {key}=A,B)" if key in study.sweepable else ""
        also = " (--backend is --set backend=...)" if key == "backend" else ""
        raise UserError(f"{option} {key} is given {given.count(key)} times{also}; give each setting once{sweep}")
    defaults = default_settings(study)
    out = {}
    for key, text in pairs:
        default = defaults.get(key)
        labels = lookup(key).choices is not None or isinstance(default, (str, bool))
        out[key] = _value(key, text, default, labels)
    return out


def _value(key: str, text: str, default, labels: bool):
    """One ``--set`` text as a value (see :func:`setting_values`)."""
    if ":" in text and not labels:
        return _linspace(key, text)
    if "," in text:
        items = [t.strip() for t in text.split(",")]
        if any(not t for t in items):
            raise UserError(f"setting {key}={text}: empty item in the list")
        if len(items) > MAX_AXIS:
            raise UserError(f"setting {key}: at most {MAX_AXIS} values per swept setting; got {len(items)}")
        return tuple(items) if labels else tuple(_float(key, t) for t in items)
    if labels and not isinstance(default, bool):
        return text  # a label (checked against the setting's choices by study.checks)
    if default is None or isinstance(default, tuple) or (not isinstance(default, bool) and lookup(key).sweep):
        default = 1.0  # a swept setting held at one value: a number
    return _convert(key, text, default)


def _linspace(key: str, text: str) -> tuple:
    """``start:stop:num`` as the tuple of ``numpy.linspace(start, stop, num)`` (floats)."""
    parts = text.split(":")
    if len(parts) != 3:
        raise UserError(f"setting {key}={text}: a range is start:stop:num, e.g. {key}=0.4:0.6:5")
    start, stop = _float(key, parts[0]), _float(key, parts[1])
    try:
        num = integer(parts[2])
    except ValueError:
        raise UserError(f"setting {key}={text}: num of start:stop:num must be an integer") from None
    if num < 2:
        raise UserError(f"setting {key}={text}: a range needs num >= 2 points (give one value as a scalar)")
    if num > MAX_AXIS:
        raise UserError(f"setting {key}={text}: at most {MAX_AXIS} values per swept setting; got {num}")
    if not (math.isfinite(start) and math.isfinite(stop)) or start == stop:
        raise UserError(f"setting {key}={text}: a range needs finite start != stop")
    with np.errstate(over="ignore", invalid="ignore"):  # stop - start beyond the largest float
        values = np.linspace(start, stop, num)
    if not np.all(np.isfinite(values)):
        raise UserError(f"setting {key}={text}: the range's points are not finite numbers (start and stop too far "
                        "apart for a float)")
    return tuple(float(v) for v in values)


def _float(key: str, text: str) -> float:
    try:
        return number(text)
    except ValueError:
        raise UserError(f"setting {key}={text}: expected a number") from None


def _convert(key: str, text: str, default):
    """``text`` as the type of ``default`` (physical keys are floats; 'inf' allowed)."""
    try:
        if isinstance(default, bool):
            if text.lower() in ("1", "true", "yes", "on"):
                return True
            if text.lower() in ("0", "false", "no", "off"):
                return False
            raise ValueError
        if isinstance(default, int):
            return integer(text)
        if isinstance(default, float):
            return number(text)
        return text
    except ValueError:
        kind = {bool: "true/false", int: "an integer", float: "a number"}.get(type(default), type(default).__name__)
        raise UserError(f"setting {key}={text}: expected {kind}") from None


def words(values: dict) -> list[str]:
    """``values`` (``{key: value}``) as ``--set`` words, ``KEY=TEXT`` (a tuple as ``a,b,c``): what a
    file records of the settings a run was given (``study.reference`` provenance)."""
    def text(v):
        if isinstance(v, (tuple, list)):
            return ",".join(text(x) for x in v)
        if isinstance(v, bool):
            return "true" if v else "false"
        return repr(v) if isinstance(v, float) else str(v)

    return [f"{key}={text(value)}" for key, value in values.items()]
