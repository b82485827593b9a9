"""Predictability of a shot: basin entropy, uncertainty exponent and make probabilities.

Pure numpy on top of ``solver.simulate``; no xarray, no I/O. Outcome codes are any
integers (``solver.OUTCOME_MEANINGS`` may grow): nothing here assumes four of them.

- ``basin_entropy`` (Daza, Wagemakers, Georgeot, Guery-Odelin, Sanjuan, Sci. Rep. 6,
  31416, 2016): split an outcome grid into boxes of ``box`` points per side; the entropy of a
  box is the Shannon entropy (natural log, [nats]) of the fractions of the outcomes in it.
  S_b is its mean over all boxes, S_bb the mean over the boundary boxes (those holding more
  than one outcome). S_b = 0 for a single outcome; S_bb <= ln k with k outcomes. The
  **ln 2 criterion**: S_bb > ln 2 is sufficient (not necessary) for the boundary to be fractal;
  a smooth boundary between two outcomes gives S_bb < ln 2.
- ``uncertainty_fraction`` / ``perturbation_fraction`` (McDonald, Grebogi, Ott, Yorke,
  Physica D 17, 125, 1985): the fraction f(eps) of states whose outcome changes when one
  component k is moved by +-eps * scale[k] (any k with scale[k] > 0); ``grid_uncertainty_fraction``
  reads the same from an outcome grid at eps = whole grid steps. f(eps) ~ eps^alpha:
  ``uncertainty_exponent`` fits alpha; the boundary's box dimension is D = d - alpha in a
  d-dimensional section (alpha = 1 for a smooth boundary, alpha < 1 for a fractal one).
- ``make_probability``: the Monte Carlo probability of each outcome when the arriving
  state is normal around a nominal one, with Wilson confidence intervals (``wilson_interval``).
"""

from __future__ import annotations

from collections.abc import Callable
from typing import NamedTuple

import numpy as np
from scipy.special import ndtri

from rimroll.solver._arguments import check_size
from rimroll.solver.engine.outcomes import OUTCOME_MEANINGS
from rimroll.solver.physics.params import Params

LN2 = float(np.log(2.0))
"""S_bb above ln 2 [nats] is sufficient for a fractal boundary (Daza et al. 2016)."""


# ================================================================ basin entropy
class BasinEntropy(NamedTuple):
    S_b: float  # mean entropy over all boxes [nats]
    S_bb: float  # mean entropy over boundary boxes [nats]; NaN when there is none
    n_boxes: int
    n_boundary_boxes: int


def _as_codes(codes) -> np.ndarray:
    a = np.asarray(codes)
    if a.ndim < 1 or a.size == 0:
        raise ValueError(f"`codes` must be a non-empty grid of integer outcome codes; got shape {a.shape}")
    if not np.issubdtype(a.dtype, np.integer):
        raise ValueError(f"`codes` must hold integers (outcome codes); got dtype {a.dtype}")
    return a


def _check_box(box, shape) -> int:
    if isinstance(box, bool) or not isinstance(box, (int, np.integer)) or box < 1:
        raise ValueError(f"`box` must be an integer >= 1 (points per side of a box); got {box!r}")
    if any(n < box for n in shape):
        raise ValueError(f"`box`={box} is larger than the grid's shape {shape}")
    return int(box)


def box_entropy(codes, box: int = 5) -> np.ndarray:
    """Shannon entropy [nats] of the outcome fractions in each box of ``box`` points per side.

    ``codes``: integer grid of any dimension d; the grid is cut into non-overlapping boxes of
    ``box``^d points starting at index 0 (trailing points that fill no whole box are left
    out). Returns an array of shape ``(n_0 // box, n_1 // box, ...)``.
    """
    a = _as_codes(codes)
    box = _check_box(box, a.shape)
    nb = tuple(n // box for n in a.shape)
    a = a[tuple(slice(0, k * box) for k in nb)]
    _, inverse = np.unique(a, return_inverse=True)
    inverse = inverse.reshape(a.shape)
    split = [s for k in nb for s in (k, box)]
    inner = tuple(range(1, 2 * a.ndim, 2))
    entropy = np.zeros(nb)
    n = float(box ** a.ndim)
    for c in range(int(inverse.max()) + 1):
        p = (inverse == c).reshape(split).sum(axis=inner) / n
        with np.errstate(divide="ignore", invalid="ignore"):
            entropy -= np.where(p > 0, p * np.log(p), 0.0)
    return np.maximum(entropy, 0.0)  # -0.0 and rounding below zero for pure boxes


def basin_entropy(codes, box: int = 5) -> BasinEntropy:
    """S_b, S_bb [nats] and the box counts of an outcome grid (Daza et al. 2016).

    Parameters
    ----------
    codes : array_like of int, any shape (d >= 1 axes)
        Outcome code of each grid point; any integers (unknown codes are outcomes too).
    box : int
        Points per side of a box (default 5, as Daza et al.).

    Returns
    -------
    BasinEntropy(S_b, S_bb, n_boxes, n_boundary_boxes): S_b the mean box entropy over all
    boxes, S_bb the mean over boxes that hold more than one outcome (NaN if none). S_bb > ln 2
    (``LN2``) is sufficient for a fractal boundary.
    """
    a = _as_codes(codes)
    box = _check_box(box, a.shape)
    nb = tuple(n // box for n in a.shape)
    a = a[tuple(slice(0, k * box) for k in nb)]
    split = [s for k in nb for s in (k, box)]
    inner = tuple(range(1, 2 * a.ndim, 2))
    blocks = a.reshape(split)
    mixed = (blocks.max(axis=inner) != blocks.min(axis=inner))
    s = box_entropy(a, box)
    n_bb = int(mixed.sum())
    s_bb = float(s[mixed].mean()) if n_bb else float("nan")
    return BasinEntropy(float(s.mean()), s_bb, int(s.size), n_bb)


# ================================================================ uncertainty fraction
class Fraction(NamedTuple):
    f: np.ndarray  # fraction of uncertain states, one per eps
    f_err: np.ndarray  # binomial standard error of f
    n: int  # states tested
    uncertain: np.ndarray  # bool (n_eps, ...): which states are uncertain at each eps


def _check_eps(eps) -> np.ndarray:
    e = np.atleast_1d(np.asarray(eps, dtype=float))
    if e.ndim != 1 or e.size == 0 or not np.all(np.isfinite(e)) or np.any(e <= 0):
        raise ValueError(f"`eps` must be one or more finite values > 0; got {eps!r}")
    return e


def _check_scale(scale) -> np.ndarray:
    s = np.asarray(scale, dtype=float)
    if s.shape != (4,) or not np.all(np.isfinite(s)) or np.any(s < 0) or not np.any(s > 0):
        raise ValueError("`scale` must be 4 finite values >= 0, not all 0: the unit of a perturbation of "
                         "(beta [rad], omega1, omega2, omega3 [1/s]); got " + repr(scale))
    return s


def perturbation_fraction(classify: Callable[[np.ndarray], np.ndarray], states, eps, scale,
                          reference=None) -> Fraction:
    """f(eps): the fraction of ``states`` whose class changes under a perturbation of size eps.

    A state x is eps-uncertain when ``classify(x +- eps * scale[k] * e_k)`` differs from
    ``classify(x)`` for some component k with ``scale[k] > 0`` and either sign (2 K copies per
    state and eps, K the number of perturbed components).

    Parameters
    ----------
    classify : callable
        Maps an array (..., m) of states to integer classes of shape (...).
    states : array_like, shape (..., m)
        The states tested (m = len(scale)).
    eps : float or sequence of float
        Perturbation sizes, in units of ``scale`` (> 0).
    scale : sequence of float, length m
        Unit of a perturbation of each component (0: that component is not perturbed).
    reference : array_like of int, shape (...), optional
        ``classify(states)`` when already known (it is not recomputed).

    Returns
    -------
    Fraction(f, f_err, n, uncertain): f and its binomial standard error sqrt(f (1 - f) / n)
    per eps, the number n of states, and the bool array (len(eps), ...) of uncertain states.
    """
    x = np.asarray(states, dtype=float)
    s = np.asarray(scale, dtype=float)
    if x.ndim < 1 or x.shape[-1] != s.size:
        raise ValueError(f"`states` must have last axis {s.size} (one per entry of `scale`); got shape {x.shape}")
    e = _check_eps(eps)
    shape = x.shape[:-1]
    ref = np.asarray(classify(x) if reference is None else reference)
    if ref.shape != shape:
        raise ValueError(f"`reference` must have shape {shape} (one class per state); got {ref.shape}")
    comps = np.nonzero(s > 0)[0]
    # One batch per (component, sign), each over every eps at once, holding only the copies of
    # states not yet found uncertain at that eps: a state is uncertain as soon as one copy
    # moves, so its other copies are never run (the definition is unchanged; near a boundary,
    # where copies are the costly ones, most states stop after one or two batches).
    flat = x.reshape(-1, s.size)
    ref_flat = ref.reshape(-1)
    uncertain = np.zeros((e.size, flat.shape[0]), dtype=bool)
    for k in comps:
        for sgn in (1.0, -1.0):
            todo_eps, todo_state = np.nonzero(~uncertain)
            if todo_eps.size == 0:
                break
            copies = flat[todo_state].copy()
            copies[:, k] += sgn * e[todo_eps] * s[k]
            moved = np.asarray(classify(copies)).reshape(-1)
            uncertain[todo_eps, todo_state] = moved != ref_flat[todo_state]
    uncertain = uncertain.reshape((e.size,) + shape)
    n = int(np.prod(shape, dtype=np.int64))
    f = uncertain.reshape(e.size, -1).mean(axis=1)
    return Fraction(f, np.sqrt(f * (1 - f) / max(n, 1)), n, uncertain)


def uncertainty_fraction(states, params: Params, eps, scale, *, reference=None, t_max=20.0, rtol=1e-8,
                         atol=1e-10, method="dp5", workers=None, **engine) -> Fraction:
    """f(eps) of rolling initial states: the fraction whose outcome changes under +-eps perturbations.

    ``states`` (..., 4) are (beta [rad], omega1, omega2, omega3 [1/s]); component k is moved by
    +-eps * scale[k] (``scale`` in rad, 1/s, 1/s, 1/s; 0 leaves it alone), one component at a
    time, and each copy is run with ``solver.simulate`` (``t_max`` [s], ``rtol``, ``atol``,
    ``method``, ``workers`` and any other keyword, ``engine``, as there). For an outcome section use
    the grid steps as ``scale``:
    then eps counts grid steps, and whole eps can be read from the grid itself
    (``grid_uncertainty_fraction``). ``reference``: the states' outcomes, when known.
    See ``perturbation_fraction`` for the returned ``Fraction``.
    """
    from rimroll.solver.engine.simulate import simulate

    def classify(x):
        return simulate(x, params, t_max=t_max, rtol=rtol, atol=atol, method=method, workers=workers,
                        **engine)["outcome"]

    return perturbation_fraction(classify, states, eps, _check_scale(scale), reference=reference)


def grid_uncertain(codes, m: int, axes=None) -> np.ndarray:
    """Bool grid: the point's code differs from the code m grid steps away along some axis.

    Both neighbours (+m, -m) along every axis in ``axes`` (default: all) are compared; at the
    edges only the neighbour inside the grid. This is ``perturbation_fraction``'s
    definition with eps = m and ``scale`` = the grid steps, read from the grid without simulation.
    """
    a = _as_codes(codes)
    if isinstance(m, bool) or not isinstance(m, (int, np.integer)) or m < 1:
        raise ValueError(f"`m` must be an integer >= 1 (grid steps); got {m!r}")
    axes = range(a.ndim) if axes is None else axes
    out = np.zeros(a.shape, dtype=bool)
    for ax in axes:
        n = a.shape[ax]
        if m >= n:
            continue
        lo = [slice(None)] * a.ndim
        hi = [slice(None)] * a.ndim
        lo[ax], hi[ax] = slice(0, n - m), slice(m, n)
        diff = a[tuple(lo)] != a[tuple(hi)]
        out[tuple(lo)] |= diff
        out[tuple(hi)] |= diff
    return out


def grid_uncertainty_fraction(codes, steps, axes=None) -> Fraction:
    """f(eps) at eps = whole grid steps ``steps`` (ints >= 1), read from an outcome grid.

    Every grid point is tested (``grid_uncertain``); returns a ``Fraction``.
    """
    a = _as_codes(codes)
    ms = [int(k) for k in np.atleast_1d(steps)]
    uncertain = np.stack([grid_uncertain(a, k, axes) for k in ms])
    f = uncertain.reshape(len(ms), -1).mean(axis=1)
    return Fraction(f, np.sqrt(f * (1 - f) / a.size), int(a.size), uncertain)


def section_uncertainty(states, codes, params: Params, eps, scale, *, n_sample: int = 4000, seed=0,
                        **simulate_kw):
    """Which points of an outcome grid are eps-uncertain, reusing the grid where it can.

    ``states`` (n_0, n_1, ..., 4) is the grid of rolling initial states whose outcomes are
    ``codes`` (n_0, n_1, ...); ``scale`` (4,) the grid steps (rad, 1/s, 1/s, 1/s; 0 for a
    component that is not an axis of the grid), so that eps counts grid steps. Each eps >= 1
    must be a whole number: those are read from the grid (``grid_uncertain``, every
    point). Each eps < 1 is simulated (``uncertainty_fraction``'s definition) on a
    stratified sample: every point that is uncertain at one grid step, plus ``n_sample``
    points drawn at random (``seed``) from the others, each standing for N_rest / n_sample
    points. A boundary that is smooth on the grid's scale has no uncertain point in the
    second stratum; a fractal one does, and that is how it is seen. ``simulate_kw`` (t_max [s],
    rtol, atol, method, workers, ...) go to ``uncertainty_fraction`` and on to ``simulate``.

    Returns
    -------
    (uncertain, weight): bool (len(eps), n_0, n_1, ...) and float (n_0, n_1, ...) [1]: the
    sampling weight of each point for eps < 1 (0: not simulated). ``sampled_fraction``
    turns them into f(eps) and its standard error.
    """
    x = np.asarray(states, dtype=float)
    c = _as_codes(codes)
    if x.shape != c.shape + (4,):
        raise ValueError(f"`states` must have shape {c.shape + (4,)} (the grid of `codes`, then 4); got {x.shape}")
    e = _check_eps(eps)
    coarse = e >= 1
    if np.any(coarse & (e != np.round(e))):
        raise ValueError(f"eps >= 1 must be whole grid steps; got {e[coarse & (e != np.round(e))].tolist()}")
    s = _check_scale(scale)
    axes = [k for k in range(c.ndim)]
    uncertain = np.zeros((e.size,) + c.shape, dtype=bool)
    for i in np.nonzero(coarse)[0]:
        uncertain[i] = grid_uncertain(c, int(e[i]), axes)
    weight = np.zeros(c.shape)
    fine = np.nonzero(~coarse)[0]
    if fine.size:
        edge = grid_uncertain(c, 1, axes).ravel()
        rest = np.nonzero(~edge)[0]
        take = np.random.default_rng(seed).choice(rest, size=min(int(n_sample), rest.size), replace=False)
        w = weight.reshape(-1)
        w[edge] = 1.0
        if take.size:
            w[take] = rest.size / take.size
        pick = np.nonzero(w > 0)[0]
        if pick.size == 0:  # no boundary on the grid and no sample asked for
            return uncertain, weight
        fr = uncertainty_fraction(x.reshape(-1, 4)[pick], params, e[fine], s, reference=c.ravel()[pick],
                                  **simulate_kw)
        for j, i in enumerate(fine):
            uncertain[i].reshape(-1)[pick] = fr.uncertain[j]
    return uncertain, weight


def _check_k(k) -> int:
    if isinstance(k, bool) or not isinstance(k, (int, np.integer)) or k < 1:
        raise ValueError(f"`k` must be an integer >= 1 (refinement factor); got {k!r}")
    return int(k)


def refined_axis(values, k: int) -> np.ndarray:
    """The axis ``values`` (n,) refined k times: (n - 1) k + 1 values, the original ones at every k-th
    place (bit for bit) and k - 1 equally spaced ones inside each interval."""
    raw = np.asarray(values)
    if raw.dtype.kind not in "iuf":
        raise ValueError(f"`values` must be real numbers; got dtype {raw.dtype}")
    v = raw.astype(float)
    if v.ndim != 1 or v.size < 2:
        raise ValueError(f"`values` must be an axis of >= 2 values; got shape {v.shape}")
    if not np.all(np.isfinite(v)):
        raise ValueError("`values` must be finite (an axis of beta [rad] or omega1 [1/s]); got NaN or inf")
    k = _check_k(k)
    inside = v[:-1, None] + (np.arange(k) / k)[None, :] * np.diff(v)[:, None]
    inside[:, 0] = v[:-1]
    return np.concatenate([inside.ravel(), v[-1:]])


def refined_uncertain(fine_codes, k: int, eps) -> np.ndarray:
    """Which points of a grid are eps-uncertain, read from its outcome grid refined k times.

    ``fine_codes`` ((n_0 - 1) k + 1, (n_1 - 1) k + 1, ...): the outcomes on the grid refined k times
    along every axis (``refined_axis``), the grid's own points at every k-th index; ``eps`` in
    grid steps, each a multiple of 1/k. Returns bool (len(eps), n_0, n_1, ...): the point's outcome
    differs from the one eps grid steps away along some axis (both sides; at the grid's edges the
    side inside only). This is ``grid_uncertain`` at eps * k fine steps, taken at the grid's
    points: the perturbed states of ``perturbation_fraction`` with ``scale`` = the grid steps
    are points of the fine grid, so every pair comes from the fine map, none is simulated here.
    """
    k = _check_k(k)
    try:
        a = _as_codes(fine_codes)
    except ValueError as exc:
        raise ValueError(str(exc).replace("`codes`", "`fine_codes`")) from None
    e = _check_eps(eps)
    steps = e * k
    if np.any(np.abs(steps - np.round(steps)) > 1e-9):
        raise ValueError(f"every eps must be a multiple of 1/k = 1/{k} grid steps; got {e.tolist()}")
    if any((n - 1) % k for n in a.shape):
        raise ValueError(f"a grid refined {k} times has (n - 1) k + 1 points per axis; got shape {a.shape}")
    at_points = tuple(slice(None, None, k) for _ in a.shape)
    return np.stack([grid_uncertain(a, int(round(m)))[at_points] for m in steps])


def sampled_fraction(uncertain, weight=None, strata=None):
    """f and its standard error from a (stratified) sample of uncertain flags.

    ``uncertain`` bool (...); ``weight`` (...) the number of points each sampled point stands
    for (0: not sampled; None: every point, weight 1); ``strata`` (...) integer or bool labels
    (None: one label). Points of equal weight and label form one stratum (the grid itself stands
    for the continuum of states, so no finite-population correction); f = sum(weight *
    uncertain) / N with N the sum of the strata's sizes N_s = weight * n_s, and its variance sums
    N_s^2 p_s (1 - p_s) / n_s / N^2 over strata. The section's eps test labels its strata by
    whether a point is uncertain at one grid step: then a test of every point and a sample of
    the second stratum estimate the same variance where the sample holds every point.
    Returns (f, f_err).
    """
    u = np.asarray(uncertain, dtype=bool).ravel()
    w = np.ones(u.shape) if weight is None else np.asarray(weight, dtype=float).ravel()
    if w.shape != u.shape:
        raise ValueError(f"`weight` must have the shape of `uncertain` {np.shape(uncertain)}; got {np.shape(weight)}")
    label = np.zeros(u.shape, dtype=np.int64) if strata is None else np.asarray(strata).astype(np.int64).ravel()
    if label.shape != u.shape:
        raise ValueError(f"`strata` must have the shape of `uncertain` {np.shape(uncertain)}; got {np.shape(strata)}")
    total, hits, var = 0.0, 0.0, 0.0
    for wv, lv in np.unique(np.stack([w, label.astype(float)], axis=1)[w > 0], axis=0):
        m = (w == wv) & (label == lv)
        n_s = int(m.sum())
        N_s = wv * n_s
        p = float(u[m].mean())
        total += N_s
        hits += N_s * p
        var += N_s ** 2 * p * (1 - p) / n_s
    if total == 0:
        return float("nan"), float("nan")
    return hits / total, float(np.sqrt(var) / total)


class Exponent(NamedTuple):
    alpha: float  # uncertainty exponent: slope of log f against log eps
    alpha_err: float  # its standard error
    D: float  # box dimension of the boundary, d - alpha
    log_f0: float  # intercept: f ~ exp(log_f0) eps^alpha


def uncertainty_exponent(eps, f, n=None, d: int = 2) -> Exponent:
    """alpha of f(eps) ~ eps^alpha by a least-squares fit of log f against log eps.

    Parameters
    ----------
    eps, f : array_like
        Perturbation sizes (> 0) and uncertain fractions; points with f = 0 are left out.
    n : array_like or int, optional
        Number of states behind each f. When given, each point is weighted by the inverse of
        the binomial variance of log f, (1 - f) / (n f); the standard error of alpha is the
        fit's formal error, scaled up by sqrt(chi^2 / dof) when the points scatter more than
        counting explains. Without ``n``: ordinary least squares and its standard error.
    d : int
        Dimension of the region sampled (2 for a (beta, omega1) section): D = d - alpha.

    Returns
    -------
    Exponent(alpha, alpha_err, D, log_f0); NaN where fewer than 2 (alpha) or 3 (alpha_err)
    points have 0 < f < 1.
    """
    e = _check_eps(eps)
    fv = np.asarray(f, dtype=float)
    if fv.shape != e.shape:
        raise ValueError(f"`f` must have one value per eps ({e.size}); got shape {fv.shape}")
    use = (fv > 0) & (fv < 1) & np.isfinite(fv)
    nan = float("nan")
    if use.sum() < 2:
        return Exponent(nan, nan, nan, nan)
    x, y = np.log(e[use]), np.log(fv[use])
    if n is None:
        w = np.ones_like(x)
    else:
        nv = np.broadcast_to(np.asarray(n, dtype=float), e.shape)[use]
        w = nv * fv[use] / (1 - fv[use])
    W = w.sum()
    if not W > 0:
        return Exponent(nan, nan, nan, nan)
    xm, ym = (w * x).sum() / W, (w * y).sum() / W
    sxx = (w * (x - xm) ** 2).sum()
    if sxx <= 0:
        return Exponent(nan, nan, nan, nan)
    alpha = float((w * (x - xm) * (y - ym)).sum() / sxx)
    log_f0 = float(ym - alpha * xm)
    dof = x.size - 2
    if dof < 1:
        err = nan
    else:
        chi2 = float((w * (y - log_f0 - alpha * x) ** 2).sum())
        if n is None:
            err = float(np.sqrt(chi2 / dof / sxx))
        else:
            err = float(np.sqrt(max(chi2 / dof, 1.0) / sxx))
    return Exponent(alpha, err, float(d - alpha), log_f0)


# ================================================================ make probability
def wilson_interval(k, n, confidence: float = 0.95):
    """Wilson score interval (lower, upper) of a binomial probability from k successes in n trials.

    Broadcasting over ``k`` and ``n`` (n >= 1); ``confidence`` in (0, 1).
    """
    if not 0 < confidence < 1:
        raise ValueError(f"`confidence` must lie in (0, 1); got {confidence!r}")
    k = np.asarray(k, dtype=float)
    n = np.asarray(n, dtype=float)
    z = float(ndtri(0.5 + confidence / 2))
    p = k / n
    denom = 1 + z * z / n
    centre = (p + z * z / (2 * n)) / denom
    half = z / denom * np.sqrt(p * (1 - p) / n + z * z / (4 * n * n))
    # exactly 0 (1) where k = 0 (k = n), as the formula is: rounding left ~3e-18 there
    lower = np.where(k == 0, 0.0, np.clip(centre - half, 0.0, 1.0))
    upper = np.where(k == n, 1.0, np.clip(centre + half, 0.0, 1.0))
    return lower, upper


def noise_draws(n_samples: int, seed) -> np.ndarray:
    """The (n_samples, 4) standard normal draws of ``make_probability`` for this seed."""
    return np.random.default_rng(seed).standard_normal((n_samples, 4))


def make_probability(states, params: Params, sigma, n_samples: int = 64, seed=0, *, confidence=0.95,
                     block: int = 262_144, **simulate_kw) -> dict:
    """Probability of each outcome when the arriving state is normal around each nominal state.

    Each nominal rolling state x (beta [rad], omega1, omega2, omega3 [1/s]) is replaced by
    ``n_samples`` states x + sigma * z_i, z_i standard normal in 4-D, each run with
    ``solver.simulate``. The draws z_i are the **same for every nominal state** (common
    random numbers, ``noise_draws`` of ``seed``): neighbouring states see the same noise,
    so a map of the probability is smooth and the result is reproducible.

    Parameters
    ----------
    states : array_like, shape (..., 4)
        Nominal rolling states.
    params : Params
    sigma : sequence of 4 floats
        Standard deviations (sigma_beta [rad], sigma_omega1, sigma_omega2, sigma_omega3
        [1/s]), >= 0. All zero: every sample is the nominal state.
    n_samples : int
        Samples per nominal state (>= 1).
    seed : int or numpy SeedSequence
        Seed of the draws.
    **simulate_kw :
        t_max [s], rtol, atol, method, workers, ...: as ``solver.simulate`` (its defaults).
    confidence : float
        Confidence level of the Wilson intervals.
    block : int
        Trajectories per call of ``simulate`` (bounds the memory).

    Returns
    -------
    dict with ``codes`` (int, (K,)): every code of ``OUTCOME_MEANINGS`` plus any other code
    that occurred; ``count`` (int, (..., K)) samples per outcome; ``probability`` (..., K);
    ``lower``, ``upper`` (..., K) the Wilson interval; ``n_samples``; ``n_failed`` (int, (...))
    samples whose ``status`` is not ok (they still count by their outcome).
    """
    from rimroll.solver.engine.simulate import simulate

    x = np.asarray(states, dtype=float)
    if x.ndim < 1 or x.shape[-1] != 4:
        raise ValueError(f"`states` must have last axis 4 (beta, omega1, omega2, omega3); got shape {x.shape}")
    sig = np.asarray(sigma, dtype=float)
    if sig.shape != (4,) or not np.all(np.isfinite(sig)) or np.any(sig < 0):
        raise ValueError("`sigma` must be 4 finite values >= 0 (sigma_beta [rad], sigma_omega1, sigma_omega2, "
                         f"sigma_omega3 [1/s]); got {sigma!r}")
    if isinstance(n_samples, bool) or not isinstance(n_samples, (int, np.integer)) or n_samples < 1:
        raise ValueError(f"`n_samples` must be an integer >= 1; got {n_samples!r}")
    if isinstance(block, bool) or not isinstance(block, (int, np.integer)) or block < 1:
        raise ValueError(f"`block` must be an integer >= 1; got {block!r}")
    if not 0 < confidence < 1:
        raise ValueError(f"`confidence` must lie in (0, 1); got {confidence!r}")
    shape = x.shape[:-1]
    flat = x.reshape(-1, 4)
    check_size("n_samples", (n_samples, 4), what="the draws (n_samples x 4)")
    check_size("n_samples", (flat.shape[0], n_samples), what="the outcomes (states x n_samples)")
    offsets = noise_draws(int(n_samples), seed) * sig
    outcome = np.empty((flat.shape[0], n_samples), dtype=np.int64)
    failed = np.zeros(flat.shape[0], dtype=np.int64)
    per = max(1, block // n_samples)  # nominal states per simulate call
    for i in range(0, flat.shape[0], per):
        sub = flat[i:i + per, None, :] + offsets[None]
        res = simulate(sub, params, **simulate_kw)
        outcome[i:i + per] = res["outcome"]
        failed[i:i + per] = (res["status"] != 0).sum(axis=1)
    codes = np.union1d(np.array(sorted(OUTCOME_MEANINGS), dtype=np.int64), np.unique(outcome))
    count = np.stack([(outcome == c).sum(axis=1) for c in codes], axis=-1)
    lower, upper = wilson_interval(count, n_samples, confidence)
    k = codes.size
    return {"codes": codes, "count": count.reshape(shape + (k,)),
            "probability": (count / n_samples).reshape(shape + (k,)),
            "lower": lower.reshape(shape + (k,)), "upper": upper.reshape(shape + (k,)),
            "n_samples": int(n_samples), "n_failed": failed.reshape(shape)}


__all__ = ["LN2", "BasinEntropy", "box_entropy", "basin_entropy", "Fraction", "perturbation_fraction",
           "uncertainty_fraction", "grid_uncertain", "grid_uncertainty_fraction", "section_uncertainty",
           "sampled_fraction", "Exponent",
           "uncertainty_exponent", "wilson_interval", "noise_draws", "make_probability"]
