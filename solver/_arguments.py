"""Argument checks of the solver's public functions (``solver.simulate``, ``solver.analysis``): each
raises ValueError naming the argument, what was given and what is allowed. Pure Python and numpy,
so that an analysis module checks its arguments without importing the engine."""

from __future__ import annotations

import math
import numbers

import numpy as np

RTOL_RANGE = (1e-14, 1e-2)
"""Relative tolerances for which the error control means something (``solver.simulate``, and the scipy
integrations of ``solver.analysis``): below 1e-14 the steps drown in round-off, above 1e-2 an
accepted step can miss the dynamics entirely (at rtol = 1 a periodic state 'falls in')."""
ATOL_MAX = 1.0
"""Largest absolute tolerance (the state's components are O(1e-2..1e2) in SI units)."""
SLIP_METHODS = ("rodas4", "explicit")
"""How ``solver.simulate`` runs slips (``switching={"slip_method": ...}``, see its docstring)."""
MAX_WORKERS = 1024
"""Most threads of the CPU backend (``simulate``'s ``workers``), and of the command line's ``--workers``
(``study.checks``): here, so that the study layer reads both without importing the engine."""
MAX_COUNT = int(np.iinfo(np.int64).max)
"""Largest count the kernels keep (``max_steps``, ``max_switches``: int64), 2**63 - 1."""


def _is_real(value) -> bool:
    """A real number: int, float, a numpy integer or floating scalar, or a 0-d array of one; not a bool,
    str, complex or None."""
    if isinstance(value, (bool, np.bool_)):
        return False
    if isinstance(value, numbers.Real):
        return True
    return getattr(value, "ndim", None) == 0 and getattr(getattr(value, "dtype", None), "kind", "") in "iuf"


def real_number(name, value, finite=True, allowed="") -> float:
    """``value`` as a float; ValueError naming ``name``, the value and what is ``allowed`` (a phrase, in
    parentheses) unless it is a real number (:func:`_is_real`), not NaN and, with ``finite``, not inf."""
    hint = f" ({allowed})" if allowed else ""
    if not _is_real(value):
        raise ValueError(f"`{name}` must be a real number{hint}; got {value!r}")
    v = float(value)
    if math.isnan(v):
        raise ValueError(f"`{name}` must be a real number, not NaN{hint}; got {value!r}")
    if finite and not math.isfinite(v):
        raise ValueError(f"`{name}` must be finite{hint}; got {value!r}")
    return v


def positive_number(name, value) -> float:
    """``value`` as a float; ValueError naming ``name`` unless it is a finite real number > 0."""
    v = real_number(name, value, allowed="> 0")
    if not v > 0:
        raise ValueError(f"`{name}` must be > 0; got {value!r}")
    return v


def tolerances(rtol, atol) -> tuple[float, float]:
    """(rtol, atol) as floats; ValueError naming the one outside RTOL_RANGE or (0, ATOL_MAX]."""
    allowed = f"in [{RTOL_RANGE[0]:g}, {RTOL_RANGE[1]:g}]"
    rtol_value = real_number("rtol", rtol, allowed=allowed)
    if not RTOL_RANGE[0] <= rtol_value <= RTOL_RANGE[1]:
        raise ValueError(f"`rtol` must be {allowed}, where the error control means something; got {rtol!r}")
    atol_value = positive_number("atol", atol)
    if atol_value > ATOL_MAX:
        raise ValueError(f"`atol` must be in (0, {ATOL_MAX:g}]; got {atol!r}")
    return rtol_value, atol_value


def nonnegative_number(name, value, allowed: str) -> float:
    """``value`` as a float; ValueError naming ``name`` and what is ``allowed`` unless it is a real number
    >= 0 (inf allowed: a friction coefficient that never slips, a throw speed without a limit)."""
    v = real_number(name, value, finite=False, allowed=allowed)
    if not v >= 0:
        raise ValueError(f"`{name}` must be {allowed}; got {value!r}")
    return v


MEMORY_FRACTION = 0.5
"""Largest share of the machine's memory one array of a computation may take (the rest: the process,
the other arrays of the same computation, the other programs)."""


def memory_limit() -> int:
    """Bytes one array may take: :data:`MEMORY_FRACTION` of the physical memory (or of the address-space
    limit ``ulimit -v``, where that is smaller); 8 GiB where neither can be read."""
    import os
    import resource

    try:
        total = os.sysconf("SC_PAGE_SIZE") * os.sysconf("SC_PHYS_PAGES")
    except (AttributeError, ValueError, OSError):
        total = 16 << 30
    soft, _ = resource.getrlimit(resource.RLIMIT_AS)
    if soft != resource.RLIM_INFINITY and 0 < soft < total:
        total = soft
    return int(total * MEMORY_FRACTION)


def check_size(name, shape, itemsize: int = 8, what: str = "") -> None:
    """The one estimate of memory before the work: ValueError naming ``name`` where an array of ``shape``
    (a tuple of counts) of ``itemsize``-byte values would not fit in :func:`memory_limit`, with the size,
    the limit and ``what`` the array is."""
    n = math.prod(int(k) for k in shape)
    need = n * int(itemsize)
    limit = memory_limit()
    if need > limit:
        dims = " x ".join(f"{int(k):,}" for k in shape)
        raise ValueError(f"`{name}`: {what or 'an array'}, {dims} values, would take {_bytes(need)} of memory; "
                         f"the limit is {_bytes(limit)} ({MEMORY_FRACTION:.0%} of this machine's memory)")


def _bytes(n: int) -> str:
    for unit, size in (("TiB", 1 << 40), ("GiB", 1 << 30), ("MiB", 1 << 20)):
        if n >= size:
            return f"{n / size:.3g} {unit}"
    return f"{n} bytes"


def one_of(name, value, allowed: tuple):
    """``value`` if it is one of the set ``allowed`` (compared by value and kind: True is not 1, 1.0 is 1);
    an array: each of its elements. Else ValueError naming ``name``, the value and the allowed ones. The
    one rule of a set-like argument."""
    if isinstance(value, np.ndarray) and value.ndim:
        for v in value.reshape(-1):
            one_of(name, v.item(), allowed)
        return value
    for item in allowed:
        if (_is_real(value) and _is_real(item)) or (isinstance(value, str) and isinstance(item, str)):
            if value == item:
                return item
        elif isinstance(value, (bool, np.bool_)) and isinstance(item, bool) and bool(value) == item:
            return item
    shown = " or ".join(repr(a) for a in allowed)
    raise ValueError(f"`{name}` must be {shown}; got {value!r}")


def integer(name, value, minimum=1, maximum=None) -> int:
    """``value`` as an int; ValueError naming ``name`` unless it is an integer (int or numpy integer, not
    bool) in [minimum, maximum] (no upper bound for ``maximum=None``)."""
    if (isinstance(value, bool) or not isinstance(value, (int, np.integer)) or value < minimum
            or (maximum is not None and value > maximum)):
        upto = "" if maximum is None else f" and <= {'2**63 - 1 (int64)' if maximum == MAX_COUNT else maximum}"
        raise ValueError(f"`{name}` must be an integer >= {minimum}{upto}; got {value!r}")
    return int(value)


def real_array(name, values) -> np.ndarray:
    """``values`` as a float array; ValueError naming ``name`` unless it is an array_like of real numbers
    (int or float; not ragged, bool, complex, strings, None). NaN and inf pass (:func:`finite_array`)."""
    try:
        raw = values if isinstance(values, np.ndarray) else np.asarray(values)
    except (ValueError, TypeError):  # ragged nesting
        raise ValueError(f"`{name}` must be an array_like of real numbers of one shape (not ragged); "
                         f"got {_short(values)}") from None
    kind = raw.dtype.kind
    if kind == "O":
        bad = [v for v in raw.flat if not _is_real(v)]
        if bad:
            bad = bad[0]
            where = f" in {_short(values)}" if raw.ndim else ""
            raise ValueError(f"`{name}` must hold real numbers (int or float); got {bad!r} "
                             f"({type(bad).__name__}, not a number){where}")
    elif kind not in "iuf":
        what = {"b": "bool", "c": "complex", "U": "strings", "S": "bytes"}.get(kind, f"dtype {raw.dtype}")
        raise ValueError(f"`{name}` must hold real numbers (int or float); got {what}: {_short(values)}")
    elif not isinstance(values, np.ndarray) and kind in "iu":  # numpy made True an int among ints
        if any(isinstance(v, (bool, np.bool_)) for v in np.asarray(values, dtype=object).flat):
            raise ValueError(f"`{name}` must hold real numbers (int or float); got a bool in {_short(values)}")
    return raw.astype(float, copy=False)


def finite_array(name, x: np.ndarray) -> None:
    """ValueError naming ``name`` and the first non-finite entry of the float array ``x``."""
    finite = np.isfinite(x)
    if not finite.all():
        where = np.unravel_index(int(np.argmin(finite)), x.shape) if x.ndim else ()
        raise ValueError(f"`{name}` must be finite; got {float(x[where])!r} at index {tuple(map(int, where))} "
                         f"({int(finite.size - finite.sum())} of {finite.size} entries inf or NaN)")


def _short(values, n=80) -> str:
    text = repr(values)
    return text if len(text) <= n else text[:n - 3] + "..."
