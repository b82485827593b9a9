"""Bootstrap error of the uncertainty exponent alpha: over the sampled states and over eps ranges.

``solver.analysis.predictability.uncertainty_exponent`` fits alpha to f(eps) with the fit's
standard error, which takes the f(eps) as independent. They are not: every f(eps) counts the
same states, so a few unlucky states near a boundary move all of them together, and the fit's
error says nothing about how alpha depends on which eps are fitted. :func:`bootstrap_exponent`
resamples the states instead:

- **States.** A replicate draws the grid's N points with replacement (the Poisson bootstrap:
  independent counts c ~ Poisson(1) per point, the large-N limit of drawing N of N). At a whole
  eps (read from the grid, every point known) f* = sum(c u) / sum(c). Below one grid step, the
  uncertain flags are known on a two-phase sample (``section_uncertainty``): every point of the
  *edge* stratum (uncertain at one grid step) and a random subset of the *rest*; then
  f* = (sum over edge points of c u + (drawn rest points) x (uncertain share of the drawn
  sampled rest points)) / sum(c), which is ``sampled_fraction``'s estimate when every c = 1. The
  same draw serves every eps, so their correlation is kept.
- **eps ranges.** Each replicate also fits a contiguous window of the eps, of at least
  ``min_points`` values, picked at random among all such windows (the whole range included): a
  curvature of log f against log eps (a range where the boundary looks rougher) widens the spread.

Each replicate fits alpha like the nominal estimate (the same weights ``n``). Reported: the
standard deviation of the replicates (states only, whole range; and states with eps windows) and
the 2.5 and 97.5 % percentiles of the latter. Pure numpy.
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np

from rimroll.solver.analysis.predictability import uncertainty_exponent

BATCH = 64  # replicates drawn at once: a (BATCH, N) float32 matrix of counts


class BootstrapExponent(NamedTuple):
    err_states: float  # std of alpha over replicates resampling the states, whole eps range [1]
    err: float  # std of alpha over replicates resampling the states and the eps window [1]
    low: float  # 2.5 % percentile of the latter [1]
    high: float  # 97.5 % percentile of the latter [1]
    replicates: np.ndarray  # (n_boot, 2): alpha of each replicate, whole range and random window [1]


def windows(n_eps: int, min_points: int = 3) -> list[tuple[int, int]]:
    """Every contiguous window [start, stop) of at least ``min_points`` of ``n_eps`` eps values."""
    return [(a, b) for a in range(n_eps) for b in range(a + min_points, n_eps + 1)]


def _check(e, u, sampled, rest) -> None:
    if u.ndim != 2 or u.shape[0] != e.size:
        raise ValueError(f"`uncertain` must have shape (len(eps) = {e.size}, N); got {u.shape}")
    if sampled.shape != (u.shape[1],) or rest.shape != (u.shape[1],):
        raise ValueError(f"`sampled` and `rest` must have shape ({u.shape[1]},); got {sampled.shape}, {rest.shape}")
    if np.any(~rest & ~sampled) and np.any(e < 1):
        raise ValueError("every edge point (rest False) must be sampled: its flags below one grid step are needed")


class _Parts(NamedTuple):
    """What :func:`_fractions` needs, as float32 matrices (n_eps, N) and vectors (N,)."""
    all_u: np.ndarray
    edge_u: np.ndarray
    rest_u: np.ndarray
    rest_s: np.ndarray
    rest_f: np.ndarray
    fine: np.ndarray


def _parts(e, u, sampled, rest) -> _Parts:
    f32 = np.float32
    return _Parts(u.astype(f32), (u & ~rest).astype(f32), (u & rest & sampled).astype(f32),
                  (rest & sampled).astype(f32), rest.astype(f32), e < 1)


def _fractions(parts: _Parts, c, c_more_rest) -> np.ndarray:
    """f (k, n_eps) of k resamplings: ``c`` (k, N) counts of the points, ``c_more_rest`` (k,) the total
    count of further rest points that are never uncertain and not sampled."""
    total = c.sum(axis=1) + c_more_rest
    f = (c @ parts.all_u.T) / total[:, None]
    if parts.fine.any():
        drawn_rest, drawn_s = c @ parts.rest_f + c_more_rest, c @ parts.rest_s
        with np.errstate(invalid="ignore", divide="ignore"):
            share = np.where(drawn_s[:, None] > 0, (c @ parts.rest_u.T) / drawn_s[:, None], 0.0)
        f_fine = ((c @ parts.edge_u.T) + drawn_rest[:, None] * share) / total[:, None]
        f[:, parts.fine] = f_fine[:, parts.fine]
    return f


def fractions(eps, uncertain, sampled, rest, counts) -> np.ndarray:
    """f(eps) [1] of resamplings of the grid's points, as :func:`bootstrap_exponent` forms them.

    ``counts`` (k, N): how often each point is drawn in each of k resamplings (all ones: the
    nominal f of ``predictability.sampled_fraction``); the other arguments as for
    :func:`bootstrap_exponent`. Returns (k, n_eps).
    """
    e = np.asarray(eps, dtype=float).ravel()
    u = np.asarray(uncertain, dtype=bool)
    sampled, rest = np.asarray(sampled, dtype=bool).ravel(), np.asarray(rest, dtype=bool).ravel()
    _check(e, u, sampled, rest)
    c = np.atleast_2d(np.asarray(counts, dtype=np.float32))
    if c.shape[1] != u.shape[1]:
        raise ValueError(f"`counts` must have shape (k, {u.shape[1]}); got {c.shape}")
    return _fractions(_parts(e, u, sampled, rest), c, np.zeros(c.shape[0], np.float32))


def bootstrap_exponent(eps, uncertain, sampled, rest, n=None, *, n_boot: int = 1000, seed=0,
                       min_points: int = 3) -> BootstrapExponent:
    """Bootstrap spread of alpha (see the module docstring).

    Parameters
    ----------
    eps : (n_eps,) float
        Perturbation sizes [grid steps]; those >= 1 are read from the whole grid.
    uncertain : (n_eps, N) bool
        Uncertain flag of every grid point at each eps (below one step: meaningful where ``sampled``).
    sampled : (N,) bool
        Points whose flags below one grid step are known (every edge point, and the random
        sample of the rest).
    rest : (N,) bool
        Points of the second stratum (certain at one grid step).
    n : (n_eps,) float, optional
        Weights of the fit, as ``uncertainty_exponent``'s ``n`` (the nominal effective counts).
    n_boot : int
        Replicates (>= 2).
    seed : int
        Seed of the draws.
    min_points : int
        Smallest window of eps fitted (>= 2).

    Returns
    -------
    :class:`BootstrapExponent`; NaN where fewer than two replicates give a finite alpha.
    """
    e = np.asarray(eps, dtype=float).ravel()
    u = np.asarray(uncertain, dtype=bool)
    sampled, rest = np.asarray(sampled, dtype=bool).ravel(), np.asarray(rest, dtype=bool).ravel()
    _check(e, u, sampled, rest)
    if isinstance(n_boot, bool) or int(n_boot) != n_boot or n_boot < 2:
        raise ValueError(f"`n_boot` must be an integer >= 2; got {n_boot!r}")
    if isinstance(min_points, bool) or int(min_points) != min_points or not 2 <= min_points <= e.size:
        raise ValueError(f"`min_points` must be an integer in [2, {e.size}]; got {min_points!r}")
    # a point of the rest never uncertain and not sampled enters only through the counts: the sum
    # of its Poisson(1) counts is one Poisson(M) draw, so only the others are drawn one by one
    inert = rest & ~sampled & ~u.any(axis=0)
    n_inert = int(inert.sum())
    parts = _parts(e, u[:, ~inert], sampled[~inert], rest[~inert])
    N = parts.all_u.shape[1]
    rng = np.random.default_rng(seed)
    wins = windows(e.size, int(min_points))
    out = np.full((int(n_boot), 2), np.nan)
    done = 0
    while done < n_boot:
        k = min(BATCH, int(n_boot) - done)
        c = rng.poisson(1.0, (k, N)).astype(np.float32)
        f = _fractions(parts, c, rng.poisson(float(n_inert), k).astype(np.float32))
        pick = rng.integers(0, len(wins), k)
        for r in range(k):
            out[done + r, 0] = uncertainty_exponent(e, f[r], n).alpha
            a, b = wins[pick[r]]
            out[done + r, 1] = uncertainty_exponent(e[a:b], f[r, a:b], None if n is None else
                                                    np.broadcast_to(np.asarray(n, float), e.shape)[a:b]).alpha
        done += k
    ok0, ok1 = np.isfinite(out[:, 0]), np.isfinite(out[:, 1])
    nan = float("nan")
    err_states = float(out[ok0, 0].std(ddof=1)) if ok0.sum() >= 2 else nan
    if ok1.sum() >= 2:
        lo, hi = np.percentile(out[ok1, 1], [2.5, 97.5])
        return BootstrapExponent(err_states, float(out[ok1, 1].std(ddof=1)), float(lo), float(hi), out)
    return BootstrapExponent(err_states, nan, nan, nan, out)
