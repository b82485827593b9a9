"""Types of the boundaries of periodic rolling on an outcome grid (paper Sect. 5.1, Fig. 10).

An outcome section (Figs. 11-13) is a 2-D grid of initial states, each with an outcome code
(``solver.engine.outcomes``), the smallest normal force ``f2_min`` [N] along the run, the
``half_period`` [s] of periodic rolling (NaN otherwise) and the run's ``t_end`` [s]. Where a
periodic cell P has a falling 4-neighbour F (fall_in or fall_out), P and F lie on a boundary of
periodic rolling, and the paper tells two kinds apart:

- **deadlock** (F2_min -> 0 at the boundary): the periodic orbits are structurally alike up to
  the boundary and their F2_min decreases continuously to zero there. Test on P: F2_min(P) is
  small against the ball's weight m g (``f2_rel``), or extrapolating F2_min linearly from the
  inner neighbour P_in through P reaches zero within ``k_cells`` grid steps beyond P.
- **separatrix** (half_period -> inf): the orbits approach a homoclinic/heteroclinic orbit of a
  saddle; F2_min jumps (stays finite on the periodic side) while the period grows without bound.
  Test (when not deadlock): the half period grows toward the boundary, hp(P) >= (1 + hp_growth)
  hp(P_in), or is long against the region's typical one, hp(P) >= hp_ratio * median(hp), or the
  falling neighbour lingers, t_end(F) >= tend_ratio * median(hp) (it passes near the saddle).
- **slipping_induced** (finite mu, only when the rolling-only outcomes of the same grid are
  given): F would roll periodically without slipping; the friction cone (39) is left before F2
  reaches zero, the "similar but stricter condition" of paper Sect. 5.2.3 (Fig. 12).
- **undetermined**: a boundary cell that passes none of the tests (e.g. too coarse a grid).
- **separatrix_and_deadlock** (only from :func:`refine_grid`): the band between the two cells,
  thinner than a grid step, holds both: a separatrix (the half period peaks without bound inside
  it) and, beyond it, the deadlock boundary where periodic rolling ends.

:func:`classify` compares neighbouring cells only, so a band thinner than a cell escapes it: on
Fig. 12's rolling-only island the separatrix at beta = 1.1346 rad lies 0.55 grid steps above a
band of periodic orbits whose F2_min falls to 0 at beta = 1.1323 rad, and the grid sees a
separatrix (the half period jumps) where the periodic region in fact ends at a deadlock.
:func:`refine_grid` therefore types every boundary pair by simulation (:func:`refine_pairs`):
bisection locates where periodic rolling ends between the two cells, F2_min there tells a
deadlock, and the half period, followed toward the boundary and searched for a peak inside the
band, tells a separatrix by its logarithmic growth.

The non-periodic side F is a fall (fall_in, fall_out) or a run still on the rim at t_max that
closed no orbit (``on_rim_at_t_max``: in a conservative scene, a period beyond t_max next to a
separatrix, or slip/roll chatter); its t_end = t_max then counts as lingering. Every other
cell is ``not_boundary``. A cell touching several
boundary pairs takes the first type in the order separatrix_and_deadlock, deadlock,
slipping_induced, separatrix, undetermined. Pure numpy; the last two axes of the arrays are the grid's
(beta, omega1) axes,
leading axes (scenes, sweeps) are classified independently.
"""

from __future__ import annotations

import numpy as np

from rimroll.solver.engine import outcomes
from rimroll.solver.engine.outcomes import code_table

BOUNDARY_TYPES = code_table("""
not_boundary: not next to a periodic/fall boundary
deadlock: F2_min of the periodic orbits decreases continuously to 0 at the boundary
separatrix: the half period grows toward the boundary (orbits near a saddle's separatrix)
slipping_induced: the falling side would roll periodically without slipping (friction cone (39))
undetermined: a periodic/fall boundary whose type the grid does not resolve
separatrix_and_deadlock: the band between the cell and its neighbour, thinner than a grid step, holds a separatrix
    (half period -> inf) and beyond it the deadlock boundary (F2_min -> 0) where periodic rolling ends
""")
BOUNDARY_MEANINGS, BOUNDARY_FLAG_VALUES, BOUNDARY_FLAG_MEANINGS = BOUNDARY_TYPES
NOT_BOUNDARY, DEADLOCK, SEPARATRIX, SLIPPING_INDUCED, UNDETERMINED, SEPARATRIX_AND_DEADLOCK = BOUNDARY_FLAG_VALUES

DEFAULTS = {
    "f2_rel": 0.1,  # F2_min(P) <= 0.1 m g: the contact is nearly lost somewhere on the orbit
    "k_cells": 1.5,  # F2_min extrapolates to 0 within 1.5 grid steps beyond P (coarse grids)
    "hp_growth": 0.02,  # hp grows by >= 2 % over the last grid step toward the boundary
    "hp_ratio": 1.5,  # or hp(P) >= 1.5 x the region's median half period
    "tend_ratio": 3.0,  # or the falling neighbour stays >= 3 median half periods on the rim
}
REFINE_DEFAULTS = {
    "n_bisect": 16,  # the boundary located to 2**-16 of the segment between the two cells
    "n_band": 8,  # uniform samples of the band from the periodic cell to the boundary
    "n_zoom": 20,  # golden-section steps on the band's largest half period (bracket shrinks 0.618**20 = 7e-5)
    "hp_log_growth": 0.02,  # separatrix: the half period still grows >= 2 % from 2**-12 to 2**-16 of the segment
                            # from the boundary, or over the last 10 golden steps onto its peak (log(1/d) law)
}
NEAREST_EXPONENT = 16
"""The growth of the half period toward the boundary is read between 2**-16 and 2**-12 of the
segment from it, also when the bisection goes finer: at rtol 1e-8 the half period is resolved
there (a separatrix adds ~0.18 s over that 16-fold approach, a deadlock ~1e-4 s), while at 2**-45
the states differ by round-off."""
_PRIORITY = (SEPARATRIX_AND_DEADLOCK, DEADLOCK, SLIPPING_INDUCED, SEPARATRIX, UNDETERMINED)
PRIORITY = _PRIORITY
"""The order in which a cell touching several boundary pairs takes their types (the first wins)."""
_GOLD = (np.sqrt(5.0) - 1.0) / 2.0


def _shift(a: np.ndarray, axis: int, step: int, fill) -> np.ndarray:
    """``a`` moved by ``step`` cells along ``axis``: out[i] = a[i - step]; ``fill`` where outside."""
    out = np.full_like(a, fill)
    n = a.shape[axis]
    src = [slice(None)] * a.ndim
    dst = [slice(None)] * a.ndim
    if abs(step) >= n:
        return out
    if step > 0:
        src[axis], dst[axis] = slice(0, n - step), slice(step, n)
    else:
        src[axis], dst[axis] = slice(-step, n), slice(0, n + step)
    out[tuple(dst)] = a[tuple(src)]
    return out


def classify(outcome, f2_min, half_period, t_end, weight: float, rolling_outcome=None,
             **thresholds) -> np.ndarray:
    """Boundary type (int8 codes of ``BOUNDARY_MEANINGS``) of every cell of outcome grids.

    Parameters
    ----------
    outcome : int array (..., n_beta, n_omega1)
        Outcome codes of ``solver.simulate``.
    f2_min : float array, same shape [N]
        Smallest normal force along each run.
    half_period : float array, same shape [s]
        Half period of periodic runs (NaN elsewhere).
    t_end : float array, same shape [s]
        End time of each run.
    weight : float [N]
        The force scale m g of the ball.
    rolling_outcome : int array, same shape, optional
        Outcomes of the same states with rolling only (mu = inf); enables ``slipping_induced``.
    thresholds : float
        Overrides of :data:`DEFAULTS` (``f2_rel``, ``k_cells``, ``hp_growth``, ``hp_ratio``,
        ``tend_ratio``); see the module docstring for their meaning.

    Returns
    -------
    int8 array of the grid's shape.
    """
    opts = dict(DEFAULTS)
    unknown = set(thresholds) - set(DEFAULTS)
    if unknown:
        raise ValueError(f"unknown thresholds {sorted(unknown)}; known: {sorted(DEFAULTS)}")
    opts.update(thresholds)
    if not (np.isfinite(weight) and weight > 0):
        raise ValueError(f"`weight` (m g) must be a positive finite force [N]; got {weight!r}")
    outcome = np.asarray(outcome)
    f2 = np.asarray(f2_min, dtype=float)
    hp = np.asarray(half_period, dtype=float)
    te = np.asarray(t_end, dtype=float)
    if outcome.ndim < 2 or not (outcome.shape == f2.shape == hp.shape == te.shape):
        raise ValueError("outcome, f2_min, half_period and t_end must share one shape with >= 2 axes; got "
                         f"{outcome.shape}, {f2.shape}, {hp.shape}, {te.shape}")
    rolling_periodic = None
    if rolling_outcome is not None:
        rolling_outcome = np.asarray(rolling_outcome)
        if rolling_outcome.shape != outcome.shape:
            raise ValueError(f"rolling_outcome has shape {rolling_outcome.shape}; expected {outcome.shape}")
        rolling_periodic = rolling_outcome == outcomes.PERIODIC_ROLLING

    periodic = outcome == outcomes.PERIODIC_ROLLING
    # the other side: a fall, or a run still on the rim at t_max without a closed orbit
    falls = (outcome == outcomes.FALL_IN) | (outcome == outcomes.FALL_OUT) | (outcome == outcomes.ON_RIM_AT_T_MAX)
    # typical half period of each grid (leading axes kept), for the absolute separatrix tests
    grid_axes = (-2, -1)
    with np.errstate(all="ignore"):
        hp_masked = np.where(periodic, hp, np.nan)
        any_periodic = periodic.any(axis=grid_axes, keepdims=True)
        hp_ref = np.where(any_periodic, np.nanmedian(np.where(any_periodic, hp_masked, 1.0),
                                                      axis=grid_axes, keepdims=True), np.nan)

    found = {code: np.zeros(outcome.shape, dtype=bool) for code in _PRIORITY}
    for axis in grid_axes:
        for step in (1, -1):
            # P at i, its falling neighbour F at i + step, its inner neighbour P_in at i - step
            f_fall = _shift(falls, axis, -step, False)
            pair = periodic & f_fall
            if not pair.any():
                continue
            f2_in = _shift(f2, axis, step, np.nan)
            hp_in = _shift(hp, axis, step, np.nan)
            in_periodic = _shift(periodic, axis, step, False)
            te_f = _shift(te, axis, -step, np.nan)
            with np.errstate(invalid="ignore"):
                slope = np.where(in_periodic, f2_in - f2, np.nan)  # F2_min decrease per step toward F
                deadlock = (f2 <= opts["f2_rel"] * weight) | (
                    (slope > 0) & (f2 <= opts["k_cells"] * slope))
                growing = in_periodic & (hp >= (1.0 + opts["hp_growth"]) * hp_in)
                separatrix = growing | (hp >= opts["hp_ratio"] * hp_ref) | (te_f >= opts["tend_ratio"] * hp_ref)
            slipping = np.zeros_like(pair)
            if rolling_periodic is not None:
                slipping = _shift(rolling_periodic, axis, -step, False)
            kinds = {DEADLOCK: deadlock, SLIPPING_INDUCED: slipping & ~deadlock,
                     SEPARATRIX: separatrix & ~deadlock & ~slipping}
            kinds[UNDETERMINED] = ~(deadlock | slipping | separatrix)
            for code, cond in kinds.items():
                hit = pair & cond
                found[code] |= hit
                found[code] |= _shift(hit, axis, step, False)  # the falling partner F gets P's type
    labels = np.full(outcome.shape, NOT_BOUNDARY, dtype=np.int8)
    for code in reversed(_PRIORITY):  # the first type in the order wins
        labels[found[code]] = code
    return labels


def boundary_pairs(outcome) -> tuple[np.ndarray, np.ndarray]:
    """The boundary pairs of one 2-D outcome grid: flat indices (periodic cell, its neighbour).

    Every periodic cell with a 4-neighbour that falls or is still on the rim at t_max (the pairs
    :func:`classify` types), each pair once. Returns two int arrays of equal length.
    """
    outcome = np.asarray(outcome)
    if outcome.ndim != 2:
        raise ValueError(f"boundary_pairs needs a 2-D (beta, omega1) grid; got shape {outcome.shape}")
    periodic = outcome == outcomes.PERIODIC_ROLLING
    other = np.isin(outcome, (outcomes.FALL_IN, outcomes.FALL_OUT, outcomes.ON_RIM_AT_T_MAX))
    index = np.arange(outcome.size).reshape(outcome.shape)
    inner, outer = [], []
    for axis in (0, 1):
        lo = [slice(None)] * 2
        hi = [slice(None)] * 2
        lo[axis], hi[axis] = slice(None, -1), slice(1, None)
        lo, hi = tuple(lo), tuple(hi)
        for p_sl, o_sl in ((lo, hi), (hi, lo)):
            hit = periodic[p_sl] & other[o_sl]
            inner.append(index[p_sl][hit])
            outer.append(index[o_sl][hit])
    return np.concatenate(inner), np.concatenate(outer)


def refine_pairs(inside, outside, params, t_max: float = 20.0, *, f2_rel: float = DEFAULTS["f2_rel"],
                 **options) -> dict:
    """Type the boundary of periodic rolling between pairs of initial states, by simulation.

    Each pair is a segment from a periodic state (``inside``) to a non-periodic one (``outside``)
    in the same conservative scene. All pairs advance together, one ``solver.simulate`` call per
    stage:

    1. **bisection** (``n_bisect`` steps) locates where periodic rolling ends: s_b, the fraction
       of the segment of the last periodic state found;
    2. **deadlock**: F2_min of that state is <= ``f2_rel`` m g (F2_min falls linearly to 0 at
       a deadlock boundary, so at 2**-16 of the segment it is ~1e-3 N; at a separatrix it stays
       near m g);
    3. **separatrix**: the half period grows like log(1/distance) toward a separatrix. It is
       sampled at ``n_band`` points of the band [0, s_b] and at distances 1, 4, ... 4**6 times
       2**-16 from s_b (:data:`NEAREST_EXPONENT`); the largest sample is followed by a
       golden-section search (``n_zoom`` steps). A separatrix is where the half period still grows
       by ``hp_log_growth`` over the 16-fold approach from 2**-12 to 2**-16, or over the last
       ``n_zoom // 2`` golden steps onto an interior peak; a smooth maximum has stopped growing
       there (by ~1e-6), a logarithmic one adds ~0.15 s per decade (Fig. 12);
    4. **slipping** (finite mu): the runs stop at the first slip (``max_switches = 0``), so the
       bisection locates where rolling stops being periodic *without slipping*; if the
       non-periodic end of the final bracket slipped, the friction cone (39) was left first.

    The type of a pair is ``separatrix_and_deadlock`` (deadlock, and a separatrix inside the
    band), ``deadlock``, ``separatrix`` (growth at the boundary), ``slipping_induced`` (the far
    end slipped), ``separatrix`` (an interior peak only), else ``undetermined``, in this order.

    Parameters
    ----------
    inside, outside : array_like (n, 4)
        (beta [rad], omega1, omega2, omega3 [1/s]) of each pair's ends.
    params : solver.Params
        A conservative scene (k_r = k_d = 0): periodic rolling is detected only there.
    t_max : float [s]
        Passed to ``solver.simulate``, with ``rtol``, ``atol``, ``method``, ``max_steps`` and
        ``workers`` from ``options``.
    f2_rel : float
        The deadlock threshold, a fraction of m g.
    options
        :data:`REFINE_DEFAULTS` (``n_bisect``, ``n_band``, ``n_zoom``, ``hp_log_growth``) and the
        keywords of ``solver.simulate`` above.

    Returns
    -------
    dict of arrays (n,): ``type`` (int8 codes), ``refined`` (False where the ends are not
    periodic / non-periodic under these rules, e.g. a periodic cell that slipped first; its type
    is then ``undetermined``), ``s_boundary`` (fraction of the segment), ``periodic``, ``other``
    ((n, 4) ends of the final bracket), ``f2_min`` [N] and ``half_period`` [s] at ``periodic``,
    ``half_period_start`` [s] at ``inside``, ``half_period_peak`` [s] and ``s_peak`` (the
    largest half period found in the band, and where), ``deadlock``, ``separatrix``,
    ``separatrix_at_boundary``, ``slipped`` (bool), ``other_outcome``, ``other_t_end`` [s];
    and ``n_runs``, the number of simulated states (an int).
    """
    opts = dict(REFINE_DEFAULTS)
    sim_kw = {k: options.pop(k) for k in list(options) if k not in REFINE_DEFAULTS}
    opts.update(options)
    allowed = {"rtol", "atol", "method", "max_steps", "workers", "switching"}
    if set(sim_kw) - allowed:
        raise ValueError(f"unknown options {sorted(set(sim_kw) - allowed)}; known: "
                         f"{sorted(REFINE_DEFAULTS)} and simulate's {sorted(allowed)}")
    if params.dissipative:
        raise ValueError("refine_pairs needs a conservative scene (k_r = k_d = 0): periodic rolling is detected "
                         f"only there; got k_r = {params.k_r}, k_d = {params.k_d}")
    seg = _Segments(inside, outside, params, t_max, sim_kw)
    n_bisect, n_band, n_zoom = int(opts["n_bisect"]), int(opts["n_band"]), int(opts["n_zoom"])
    growth = float(opts["hp_log_growth"])
    ends = seg.run(np.stack([np.zeros(seg.n), np.ones(seg.n)], axis=1))
    periodic = ends["outcome"] == outcomes.PERIODIC_ROLLING
    refined = periodic[:, 0] & ~periodic[:, 1]
    b = _bisect(seg, ends, n_bisect)
    at_boundary, S, H = _band(seg, ends, b, n_bisect, n_band, growth)
    best, s_best, best_half = _golden_peak(seg, S, H, n_zoom)
    with np.errstate(invalid="ignore"):  # -inf - -inf where a pair is not refined
        interior = np.isfinite(best_half) & (best - best_half >= growth * best)
    separatrix = at_boundary | interior
    deadlock = b["f2_lo"] <= f2_rel * params.m * params.g
    slipped = seg.hybrid & (b["other_status"] == outcomes.TOO_MANY_SWITCHES)
    kind = np.select([deadlock & separatrix, deadlock, at_boundary, slipped, interior],
                     [SEPARATRIX_AND_DEADLOCK, DEADLOCK, SEPARATRIX, SLIPPING_INDUCED, SEPARATRIX], UNDETERMINED)
    kind = np.where(refined, kind, UNDETERMINED).astype(np.int8)
    lo, hi = b["lo"], b["hi"]
    return {"type": kind, "refined": refined, "s_boundary": lo, "periodic": seg.at(lo), "other": seg.at(hi),
            "f2_min": b["f2_lo"], "half_period": b["hp_lo"], "half_period_start": ends["half_period"][:, 0],
            "half_period_peak": best, "s_peak": s_best, "deadlock": deadlock & refined,
            "separatrix": separatrix & refined, "separatrix_at_boundary": at_boundary & refined,
            "slipped": slipped & refined, "other_outcome": b["other_outcome"], "other_t_end": b["other_t_end"],
            "n_runs": seg.runs}


class _Segments:
    """The segments a -> b of :func:`refine_pairs`, simulated at fractions s of each (all pairs
    together, one ``solver.simulate`` call per stage); ``runs`` counts the simulated states."""

    def __init__(self, inside, outside, params, t_max, sim_kw):
        self.a = np.asarray(inside, dtype=float).reshape(-1, 4)
        self.b = np.asarray(outside, dtype=float).reshape(-1, 4)
        if self.a.shape != self.b.shape:
            raise ValueError(f"inside and outside must have the same shape (n, 4); got {self.a.shape}, {self.b.shape}")
        self.n = self.a.shape[0]
        self.params, self.t_max, self.sim_kw = params, t_max, dict(sim_kw)
        self.hybrid = not params.rolling_only
        if self.hybrid:
            # a slip ends the run: periodic rolling without slipping is what is bisected
            self.sim_kw["max_switches"] = 0
        self.runs = 0

    def at(self, s):
        """The states at fractions s (n,) of the segments, (n, 4)."""
        return self.a + s[:, None] * (self.b - self.a)

    def run(self, s):
        """``solver.simulate`` of the states at fractions s (n, k) or (n,) of each segment."""
        from rimroll.solver.engine.simulate import simulate

        s = np.asarray(s, dtype=float)
        lead = (self.n,) + (1,) * (s.ndim - 1) + (4,)
        x = self.a.reshape(lead) + s[..., None] * (self.b - self.a).reshape(lead)
        self.runs += s.size
        return simulate(x.reshape(s.shape + (4,)), self.params, t_max=self.t_max, **self.sim_kw)


def _half_period(r):
    """The half period of the periodic runs of a simulate result, -inf elsewhere."""
    return np.where(r["outcome"] == outcomes.PERIODIC_ROLLING, r["half_period"], -np.inf)


def _bisect(seg: _Segments, ends, n_bisect: int) -> dict:
    """Stage 1 of :func:`refine_pairs`: the bracket [lo, hi] of the end of periodic rolling, F2_min
    and the half period at lo, and the outcome, t_end and status at the far end of the bracket."""
    lo, hi = np.zeros(seg.n), np.ones(seg.n)
    f2_lo, hp_lo = ends["f2_min"][:, 0].copy(), ends["half_period"][:, 0].copy()
    other = {key: ends[key][:, 1].copy() for key in ("outcome", "t_end", "status")}
    for _ in range(n_bisect):
        mid = 0.5 * (lo + hi)
        r = seg.run(mid)
        per = r["outcome"] == outcomes.PERIODIC_ROLLING
        lo, hi = np.where(per, mid, lo), np.where(per, hi, mid)
        f2_lo, hp_lo = np.where(per, r["f2_min"], f2_lo), np.where(per, r["half_period"], hp_lo)
        other = {key: np.where(per, value, r[key]) for key, value in other.items()}
    return {"lo": lo, "hi": hi, "f2_lo": f2_lo, "hp_lo": hp_lo, "other_outcome": other["outcome"],
            "other_t_end": other["t_end"], "other_status": other["status"]}


def _band(seg: _Segments, ends, b: dict, n_bisect: int, n_band: int, growth: float):
    """Stage 3 of :func:`refine_pairs`: the half period over the band [0, lo], uniform samples and
    geometric ones toward lo from NEAREST of the segment on (finer distances than the integration
    resolves show no growth). Returns (growth at the boundary, the sample fractions S and half
    periods H, sorted by S, with the ends included)."""
    lo = b["lo"]
    nearest = 2.0 ** -min(n_bisect, NEAREST_EXPONENT)
    uniform = lo[:, None] * (np.arange(1, n_band) / n_band)[None, :]
    geometric = np.clip(lo[:, None] - nearest * 4.0 ** np.arange(0, 7)[None, :], 0.0, None)
    h_band = _half_period(seg.run(np.concatenate([uniform, geometric], axis=1)))
    h_near, h_far = h_band[:, n_band - 1], h_band[:, n_band + 1]  # at nearest and 16 x nearest from lo
    with np.errstate(invalid="ignore"):  # -inf - -inf where a sample is not periodic
        at_boundary = np.isfinite(h_near) & np.isfinite(h_far) & (h_near - h_far >= growth * h_near)
    S = np.concatenate([np.zeros((seg.n, 1)), uniform, geometric, lo[:, None]], axis=1)
    H = np.concatenate([ends["half_period"][:, :1], h_band, b["hp_lo"][:, None]], axis=1)
    H = np.where(np.isnan(H), -np.inf, H)  # a pair that is not refined has no half period at its ends
    order = np.argsort(S, axis=1, kind="stable")
    return at_boundary, np.take_along_axis(S, order, 1), np.take_along_axis(H, order, 1)


def _golden_peak(seg: _Segments, S, H, n_zoom: int):
    """The largest half period of each band: a golden-section search around its largest sample.
    Returns (the largest half period [s], where (a fraction), the largest after n_zoom // 2 steps)."""
    k = np.arange(seg.n)
    m = np.argmax(H, axis=1)
    best, s_best = H[k, m], S[k, m]
    left, right = S[k, np.maximum(m - 1, 0)], S[k, np.minimum(m + 1, S.shape[1] - 1)]
    x1, x2 = right - _GOLD * (right - left), left + _GOLD * (right - left)
    h = _half_period(seg.run(np.stack([x1, x2], axis=1)))
    h1, h2 = h[:, 0], h[:, 1]
    best_half = best
    for step in range(n_zoom):
        right_side = h2 > h1  # the larger value brackets the peak: keep its side
        left, right = np.where(right_side, x1, left), np.where(right_side, right, x2)
        x_new = np.where(right_side, left + _GOLD * (right - left), right - _GOLD * (right - left))
        h_new = _half_period(seg.run(x_new))
        x1, x2 = np.where(right_side, x2, x_new), np.where(right_side, x_new, x1)
        h1, h2 = np.where(right_side, h2, h_new), np.where(right_side, h_new, h1)
        better = h_new > best
        best, s_best = np.where(better, h_new, best), np.where(better, x_new, s_best)
        if step == n_zoom // 2 - 1:
            best_half = best
    return best, s_best, best_half


def refine_grid(outcome, states, params, t_max: float, fallback=None, **options) -> tuple[np.ndarray, dict]:
    """Boundary types of one 2-D outcome grid from its boundary pairs refined by simulation.

    Every pair of :func:`boundary_pairs` is typed by :func:`refine_pairs`; each cell takes the
    first type of its pairs in the order of ``classify`` (separatrix_and_deadlock first). Pairs
    that cannot be refined keep the label of their periodic cell in ``fallback`` (e.g. the
    grid's :func:`classify`), or ``undetermined``.

    Parameters
    ----------
    outcome : int array (n_beta, n_omega1)
        Outcome codes of the grid's runs under ``params``.
    states : float array (n_beta, n_omega1, 4)
        The grid's initial states (beta [rad], omega1, omega2, omega3 [1/s]).
    params, t_max, options
        As for :func:`refine_pairs` (the grid's own scene, t_max [s] and tolerances).
    fallback : int array (n_beta, n_omega1), optional
        Labels for pairs that cannot be refined.

    Returns
    -------
    (labels, summary): int8 array of the grid's shape, and a dict with ``pairs`` (number of
    boundary pairs), ``refined`` (how many were refined), ``runs`` (states simulated) and
    ``pair_types`` (int8 type of each pair, in the order of :func:`boundary_pairs`).
    """
    outcome = np.asarray(outcome)
    states = np.asarray(states, dtype=float)
    if states.shape != outcome.shape + (4,):
        raise ValueError(f"states must have shape {outcome.shape + (4,)}; got {states.shape}")
    inner, outer = boundary_pairs(outcome)
    labels = np.full(outcome.size, NOT_BOUNDARY, dtype=np.int8)
    summary = {"pairs": int(inner.size), "refined": 0, "runs": 0, "pair_types": np.zeros(0, dtype=np.int8)}
    if inner.size == 0:
        return labels.reshape(outcome.shape), summary
    flat = states.reshape(-1, 4)
    res = refine_pairs(flat[inner], flat[outer], params, t_max, **options)
    kind = res["type"].copy()
    if fallback is not None:
        kind = np.where(res["refined"], kind, np.asarray(fallback).reshape(-1)[inner]).astype(np.int8)
    rank = np.full(max(BOUNDARY_FLAG_VALUES) + 1, len(_PRIORITY), dtype=np.int64)
    for position, code in enumerate(_PRIORITY):
        rank[code] = position
    best = np.full(outcome.size, len(_PRIORITY), dtype=np.int64)
    for cells in (inner, outer):
        np.minimum.at(best, cells, rank[kind])
    typed = best < len(_PRIORITY)
    labels[typed] = np.asarray(_PRIORITY)[best[typed]]
    summary.update(refined=int(res["refined"].sum()), runs=int(res["n_runs"]), pair_types=kind)
    return labels.reshape(outcome.shape), summary


def refine(periodic_state, other_state, params, n_bisect: int = 30, t_max: float = 20.0,
           **simulate_kw) -> dict:
    """Type the boundary between one periodic and one non-periodic initial state (:func:`refine_pairs`).

    What a grid cannot resolve (a boundary band thinner than a cell), bisection can: F2_min
    and the half period of the last periodic state, ``2**-n_bisect`` of the segment from the
    boundary, tell deadlock (F2_min -> 0) from separatrix (half period -> inf), and a search of
    the band finds a separatrix inside it.

    Parameters
    ----------
    periodic_state, other_state : array_like (4,)
        (beta [rad], omega1, omega2, omega3 [1/s]); the first must roll periodically, the
        second must not (fall or on_rim_at_t_max) under ``params``.
    params : solver.Params
        A conservative scene (periodic detection on).
    n_bisect : int
        Bisection steps (the bracket shrinks to 2**-n_bisect of the segment).
    t_max : float [s], simulate_kw
        Passed to :func:`solver.simulate` (rtol, atol, method, max_steps ...), and the options
        ``n_band``, ``n_zoom``, ``hp_log_growth`` of :func:`refine_pairs`.

    Returns
    -------
    dict: ``periodic`` and ``other`` (the final bracket, arrays (4,)), ``f2_min`` [N] and
    ``half_period`` [s] of the bracket's periodic end, ``half_period_start`` [s] of
    ``periodic_state``, ``half_period_peak`` [s] and ``s_peak`` (the band's largest half
    period and where, as a fraction of the segment), ``other_outcome`` (code), ``other_t_end``
    [s], ``type`` (a code of :data:`BOUNDARY_MEANINGS`) and ``n_runs``.
    """
    kw = dict(simulate_kw)
    kw.setdefault("workers", 1)
    r = refine_pairs(np.asarray(periodic_state, dtype=float)[None, :], np.asarray(other_state, dtype=float)[None, :],
                     params, t_max, n_bisect=n_bisect, **kw)
    if not r["refined"][0]:
        raise ValueError("refine needs a periodic and a non-periodic end (without a slip before the periodic orbit "
                         "with finite mu)")
    out = {key: r[key][0] for key in ("periodic", "other", "other_outcome")}
    out.update({key: float(r[key][0]) for key in ("f2_min", "half_period", "half_period_start", "half_period_peak",
                                                  "s_peak", "other_t_end")})
    out.update(type=int(r["type"][0]), other_outcome=int(r["other_outcome"][0]), n_runs=r["n_runs"])
    return out


__all__ = ["classify", "boundary_pairs", "refine_pairs", "refine_grid", "refine", "BOUNDARY_MEANINGS",
           "BOUNDARY_FLAG_VALUES", "BOUNDARY_FLAG_MEANINGS", "DEFAULTS", "REFINE_DEFAULTS", "NOT_BOUNDARY", "DEADLOCK",
           "SEPARATRIX", "SLIPPING_INDUCED", "UNDETERMINED", "SEPARATRIX_AND_DEADLOCK"]
