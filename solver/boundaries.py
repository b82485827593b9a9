"""Types of the boundaries of periodic rolling on an outcome grid (paper Sect. 5.1, Fig. 10).

An outcome section (Figs. 11-13) is a 2-D grid of initial states, each with an outcome code
(``solver.outcomes``), the smallest normal force ``f2_min`` [N] along the run, the
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

The non-periodic side F is a fall (fall_in, fall_out) or a run still on the rim at t_max that
closed no orbit (``on_rim_at_t_max``: in a conservative scene, a period beyond t_max next to a
separatrix, or slip/roll chatter); its t_end = t_max then counts as lingering. Every other
cell is ``not_boundary``. A cell touching several
boundary pairs takes the first type in the order deadlock, slipping_induced, separatrix,
undetermined. Pure numpy; the last two axes of the arrays are the grid's (beta, omega1) axes,
leading axes (scenes, sweeps) are classified independently.
"""

from __future__ import annotations

import numpy as np

from solver import outcomes

NOT_BOUNDARY = 0
DEADLOCK = 1
SEPARATRIX = 2
SLIPPING_INDUCED = 3
UNDETERMINED = 4

BOUNDARY_MEANINGS = {
    NOT_BOUNDARY: "not_boundary: not next to a periodic/fall boundary",
    DEADLOCK: "deadlock: F2_min of the periodic orbits decreases continuously to 0 at the boundary",
    SEPARATRIX: "separatrix: the half period grows toward the boundary (orbits near a saddle's separatrix)",
    SLIPPING_INDUCED: "slipping_induced: the falling side would roll periodically without slipping (friction cone (39))",
    UNDETERMINED: "undetermined: a periodic/fall boundary whose type the grid does not resolve",
}
BOUNDARY_FLAG_VALUES = tuple(BOUNDARY_MEANINGS)
BOUNDARY_FLAG_MEANINGS = " ".join(m.split(":")[0] for m in BOUNDARY_MEANINGS.values())

DEFAULTS = {
    "f2_rel": 0.1,  # F2_min(P) <= 0.1 m g: the contact is nearly lost somewhere on the orbit
    "k_cells": 1.5,  # F2_min extrapolates to 0 within 1.5 grid steps beyond P (coarse grids)
    "hp_growth": 0.02,  # hp grows by >= 2 % over the last grid step toward the boundary
    "hp_ratio": 1.5,  # or hp(P) >= 1.5 x the region's median half period
    "tend_ratio": 3.0,  # or the falling neighbour stays >= 3 median half periods on the rim
}
_PRIORITY = (DEADLOCK, SLIPPING_INDUCED, SEPARATRIX, UNDETERMINED)


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


def refine(periodic_state, other_state, params, n_bisect: int = 30, t_max: float = 20.0,
           **simulate_kw) -> dict:
    """Bisect the segment from a periodic initial state to a non-periodic one; type the boundary.

    What a grid cannot resolve (a boundary band thinner than a cell), bisection can: F2_min
    and the half period of the last periodic state, ``2**-n_bisect`` of the segment from the
    boundary, tell deadlock (F2_min -> 0) from separatrix (half period -> inf).

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
        Passed to :func:`solver.simulate` (rtol, atol, method, max_steps ...).

    Returns
    -------
    dict: ``periodic`` and ``other`` (the final bracket, arrays (4,)), ``f2_min`` [N] and
    ``half_period`` [s] of the bracket's periodic end, ``half_period_start`` [s] of
    ``periodic_state``, ``other_outcome`` (code), ``other_t_end`` [s] and ``type`` (DEADLOCK if
    F2_min <= f2_rel m g, else SEPARATRIX if the half period grew by hp_ratio, else
    UNDETERMINED), ``n_runs``.
    """
    from solver.simulate import simulate

    a = np.asarray(periodic_state, dtype=float).copy()
    b = np.asarray(other_state, dtype=float).copy()
    kw = dict(simulate_kw, workers=1)

    def run(x):
        r = simulate(x[None, :], params, t_max=t_max, **kw)
        return {k: v[0] for k, v in r.items()}

    ra, rb = run(a), run(b)
    if ra["outcome"] != outcomes.PERIODIC_ROLLING or rb["outcome"] == outcomes.PERIODIC_ROLLING:
        raise ValueError(f"refine needs a periodic and a non-periodic end; got outcomes {ra['outcome']}, {rb['outcome']}")
    hp_start = float(ra["half_period"])
    n_runs = 2
    for _ in range(int(n_bisect)):
        mid = 0.5 * (a + b)
        rm = run(mid)
        n_runs += 1
        if rm["outcome"] == outcomes.PERIODIC_ROLLING:
            a, ra = mid, rm
        else:
            b, rb = mid, rm
    weight = params.m * params.g
    f2, hp = float(ra["f2_min"]), float(ra["half_period"])
    if f2 <= DEFAULTS["f2_rel"] * weight:
        kind = DEADLOCK
    elif hp >= DEFAULTS["hp_ratio"] * hp_start:
        kind = SEPARATRIX
    else:
        kind = UNDETERMINED
    return {"periodic": a, "other": b, "f2_min": f2, "half_period": hp, "half_period_start": hp_start,
            "other_outcome": int(rb["outcome"]), "other_t_end": float(rb["t_end"]), "type": kind,
            "n_runs": n_runs}


__all__ = ["classify", "refine", "BOUNDARY_MEANINGS", "BOUNDARY_FLAG_VALUES", "BOUNDARY_FLAG_MEANINGS", "DEFAULTS",
           "NOT_BOUNDARY", "DEADLOCK", "SEPARATRIX", "SLIPPING_INDUCED", "UNDETERMINED"]
