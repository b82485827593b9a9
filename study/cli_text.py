"""The one parser of ``KEY=VALUE`` words on the command line (``--set``, ``--select``, ``--at``).

One rule serves both meanings of a comma: a word is split on commas, and a piece without ``=``
continues the value of the pair before it. So ``mu=0.5,1,2`` is one key with the list value
``0.5,1,2`` (``--set``), while ``omega1=0.5,beta=1.2`` is two pairs (``--at``, ``--select``).
Keys and values are stripped of surrounding blanks; a word whose first piece has no ``=``, or
that gives an empty key or an empty value, is a one-line :class:`~rimroll.study.registry.UserError`
naming the option, the word and the form expected. What a value means (a number, a list, a
label) is left to the caller.
"""

from __future__ import annotations

from rimroll.study.registry import UserError


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
