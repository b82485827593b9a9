"""Benchmark of the slipping scene (not a test): its cost against rolling only, and what bounds it.

    python benchmarks/slipping_cost.py [--quick] [--sample N] [--omega2 35|65]

The slipping scene (mu = 1) was asked to cost at most 3x (issue 3), then 4x (Fig. 11 section,
omega2 = 35 1/s) and 6x (Fig. 12 section, omega2 = 65 1/s) the rolling-only time (omega3 = 10 1/s,
240 x 360 states, rtol 1e-8, atol 1e-10). This script measures, in one run on the same states:

1. wall time of ``solver.simulate`` in both scenes (best of 3, warm cache, all cores), and the
   attempted steps per state;
2. on a seeded sample of the states that slip, the accepted steps that ``scipy.integrate.solve_ivp``
   needs for the same trajectories at the same tolerances (``solver.analysis.scipy_reference.reference_hybrid``:
   same rules, phase by phase), split into rolling and slipping phases, for RK45 (the explicit
   Dormand-Prince pair the engine uses by default), DOP853 (its higher-order one) and for the
   implicit Radau and BDF, whose steps are not limited by the stiffness of the slip angle but only
   by accuracy;
3. from 2, an estimate of the slipping/rolling ratio each method would allow: the states that
   never slip cost their rolling-only steps; the states that slip cost the engine's steps on them,
   scaled by (RK45 rolling-phase + the method's slipping-phase steps) / (engine's steps) on the
   sample (a ratio estimator, so the sample's mix of short and long slips cancels); every step is
   priced at one explicit Dormand-Prince step, which is optimistic for DOP853 (twice the stages),
   Radau and BDF (each of their steps solves a Newton system), so for them the figure is a lower
   bound.

If even the implicit methods' bound exceeds the target, no integrator of the slipping equations (42) at
this tolerance can meet the target; only a change of model (for example a reduced slip along
the limit direction while the slip is small) could.
"""

from __future__ import annotations

import argparse
import time

import numpy as np

from rimroll import solver
from rimroll.solver.analysis.scipy_reference import reference_hybrid

RTOL, ATOL, T_MAX = 1e-8, 1e-10, 20.0


TARGETS = {35.0: 4.0, 65.0: 6.0}
"""The asked ratio slipping / rolling only of each section, by omega2 [1/s] (issue 22)."""


def section(quick: bool, omega2: float) -> np.ndarray:
    """The (beta, omega1) section at omega2 [1/s], omega3 = 10 1/s: 240 x 360 states (60 x 90 quick)."""
    n_beta, n_omega1 = (60, 90) if quick else (240, 360)
    beta, omega1 = np.meshgrid(np.linspace(0.8, 1.8, n_beta), np.linspace(-20, 20, n_omega1), indexing="ij")
    return np.stack([beta, omega1, np.full_like(beta, omega2), np.full_like(beta, 10.0)], axis=-1).reshape(-1, 4)


def timed(states, params, repeats=3):
    best, res = np.inf, None
    for _ in range(repeats):
        t0 = time.perf_counter()
        res = solver.simulate(states, params, t_max=T_MAX, rtol=RTOL, atol=ATOL, method="dp5")
        best = min(best, time.perf_counter() - t0)
    return best, res


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--quick", action="store_true", help="a 60 x 90 section instead of 240 x 360")
    ap.add_argument("--sample", type=int, default=40, help="slipping states run through scipy (default 40)")
    ap.add_argument("--omega2", type=float, choices=sorted(TARGETS), default=35.0,
                    help="the section: 35 (Fig. 11, default) or 65 1/s (Fig. 12)")
    args = ap.parse_args()
    target = TARGETS[args.omega2]

    states = section(args.quick, args.omega2)
    rolling_only, slipping = solver.Params(mu=np.inf), solver.Params(mu=1.0)
    solver.simulate(states[:4], rolling_only, method="dp5")  # compile or load the kernels first
    solver.simulate(states[:4], slipping)
    t_roll, r_roll = timed(states, rolling_only)
    t_slip, r_slip = timed(states, slipping)
    slips = r_slip["slip_phases"] > 0
    n, n_slip = len(states), int(slips.sum())
    print(f"section omega2 = {args.omega2:g} 1/s: {n} states, rtol {RTOL:g}, atol {ATOL:g}, t_max {T_MAX:g} s; "
          f"{n_slip} states slip ({n_slip / n:.1%}), mean slip phases {r_slip['slip_phases'][slips].mean():.2f}")
    print(f"rolling only : {t_roll:.3f} s wall, {r_roll['n_steps'].mean():.1f} steps/state")
    print(f"slipping mu=1: {t_slip:.3f} s wall, {r_slip['n_steps'].mean():.1f} steps/state, "
          f"{r_slip['n_steps'][slips].mean():.1f} per slipping state")
    print(f"measured ratio slipping / rolling only: {t_slip / t_roll:.2f}x (target <= {target:g}x)")

    rng = np.random.default_rng(20261122)
    picked = rng.choice(np.flatnonzero(slips), size=min(args.sample, n_slip), replace=False)
    steps = {}
    for method in ("RK45", "DOP853", "Radau", "BDF"):
        rows = [reference_hybrid(states[k], slipping, t_max=T_MAX, rtol=RTOL, atol=ATOL, method=method)
                for k in picked]
        steps[method] = (np.mean([r["steps_rolling"] for r in rows]), np.mean([r["steps_slipping"] for r in rows]))
        agree = np.mean([r["outcome"] == r_slip["outcome"][k] for r, k in zip(rows, picked)])
        print(f"scipy {method:5s} on {len(picked)} slipping states: {steps[method][0]:.1f} rolling-phase + "
              f"{steps[method][1]:.1f} slipping-phase steps per state (outcome agreement {agree:.0%})")
    ours = r_slip["n_steps"][picked].mean()
    print(f"engine on the same states: {ours:.1f} attempted steps per state (rolling and slipping phases)")

    never = r_roll["n_steps"][~slips].sum()
    total_roll = r_roll["n_steps"].sum()
    engine_slipping = r_slip["n_steps"][slips].sum()
    rolling_phase = steps["RK45"][0]
    for method, (_, slip_steps) in steps.items():
        estimate = (never + engine_slipping * (rolling_phase + slip_steps) / ours) / total_roll
        print(f"ratio with {method:5s} slipping phases, each step priced as one explicit step: {estimate:.2f}x")


if __name__ == "__main__":
    main()
