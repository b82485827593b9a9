"""The types of Theorem 1 (paper Sect. 4.4, Table 2) of states sampled from the phase space.

- ``solution-types``: the type of Theorem 1 / Table 2 of seeded states sampled from a box of the
  phase space (beta, omega1, omega2, omega3), the plane of Prop. 6, steady motions or the stable
  manifolds of saddles, from ``solver.analysis.solution_types``.
"""

from __future__ import annotations

import numpy as np

from rimroll import solver
from rimroll.solver.analysis import reduced, steady
from rimroll.solver.analysis import solution_types as st
from rimroll.study import checks
from rimroll.study import plotting as P
from rimroll.study.dataset import setting_of
from rimroll.study.registry import Axis, ReferenceSpec, Study, Var, register, with_tolerances

SUBSETS = ("box", "pendulum_plane", "steady", "connections")
MIXED = "mixed"  # the four subsets in turn: every type of Theorem 1 in one sample (the --quick run)


def _types_axes(s: dict) -> list[Axis]:
    checks.require_conservative(s, "Theorem 1 is about the conservative rolling equations")
    if s["subset"] not in (*SUBSETS, MIXED):
        raise ValueError(f"subset={s['subset']!r} is not one of {', '.join((*SUBSETS, MIXED))}")
    if int(s["n_samples"]) < 2 or not s["t_max"] > 0:
        raise ValueError(f"n_samples must be >= 2 and t_max > 0; got {s['n_samples']}, {s['t_max']}")
    return [Axis("sample", np.arange(int(s["n_samples"]), dtype=float), "1", "sample index",
                 comment="index of the seeded sample state")]


def sample_states(s: dict, p) -> np.ndarray:
    """The seeded initial states (n_samples, 4) of a ``solution_types`` run (same for every chunk).

    ``box``: uniform in beta in [-pi, pi), |omega_i| <= omega_i_max. ``pendulum_plane``: the
    plane omega2 = omega3 = 0 of Prop. 6 (beta, omega1 uniform). ``steady``: the steady motions
    (47) with beta0 uniform in [-pi, pi), |omega30| <= omega3_max, every fifth a trivial one (46).
    ``connections``: states on the stable manifolds of saddles (types 3 and 4): saddle steady
    motions (h > 0 in (54)) with beta0, omega30 drawn as in ``steady`` (draws with h <= 0 are
    skipped), every fifth the ball on top x0+ with |omega20| <= omega2_max; each state lies
    0.02-0.1 rad in beta from its saddle on the side drawn at random
    (``solver.analysis.reduced.stable_manifold_state``). ``mixed``: sample i from subset i mod 4 of
    ``box``, ``pendulum_plane``, ``steady``, ``connections`` (each drawn with seed + its position).
    """
    n = int(s["n_samples"])
    if s["subset"] == MIXED:
        out = np.empty((n, 4))
        for k, subset in enumerate(SUBSETS):
            rows = np.arange(k, n, len(SUBSETS))
            if rows.size:
                part = {**s, "subset": subset, "n_samples": rows.size, "seed": int(s["seed"]) + k}
                out[rows] = sample_states(part, p)
        return out
    rng = np.random.default_rng(int(s["seed"]))
    if s["subset"] == "connections":
        return _connection_states(n, rng, s, p)
    beta = rng.uniform(-np.pi, np.pi, n)
    w1 = rng.uniform(-1, 1, n) * s["omega1_max"]
    w2 = rng.uniform(-1, 1, n) * s["omega2_max"]
    w3 = rng.uniform(-1, 1, n) * s["omega3_max"]
    if s["subset"] == "pendulum_plane":
        w2 = np.zeros(n)
        w3 = np.zeros(n)
    elif s["subset"] == "steady":
        x = steady.steady_state(beta, w3, p)
        trivial = np.arange(n) % 5 == 4
        x[trivial] = steady.trivial_state(np.where(beta[trivial] > 0, 1, -1), w2[trivial], p)
        return x
    return np.stack([beta, w1, w2, w3], axis=-1)


def _connection_states(n: int, rng, s: dict, p) -> np.ndarray:
    out = np.empty((n, 4))
    for i in range(n):
        offset = rng.choice([-1.0, 1.0]) * rng.uniform(0.02, 0.1)
        if i % 5 == 4:
            saddle = steady.trivial_state(1, rng.uniform(-1, 1) * s["omega2_max"], p)
        else:
            while True:  # rejection: a saddle steady motion
                beta0, w30 = rng.uniform(-np.pi, np.pi), rng.uniform(-1, 1) * s["omega3_max"]
                if steady.stability(beta0, w30, p) > 0:
                    break
            saddle = steady.steady_state(beta0, w30, p)
        for _ in range(8):  # halve an offset that reaches past the saddle's potential hill
            try:
                out[i] = reduced.stable_manifold_state(saddle, offset, p)
                break
            except ValueError:
                offset /= 2.0
        else:
            raise ValueError(f"no state on the stable manifold of the saddle {saddle} within 1e-3 rad")
    return out


def _types_compute(coords, p, s):
    idx = coords[0].astype(int)
    x = sample_states(s, p)[idx]
    res = st.classify(x, p, t_max=s["t_max"], rtol=s["rtol"], atol=s["atol"])
    e = solver.invariants(x, p)["E"]
    return {**res, "beta_init": x[..., 0], "omega1_init": x[..., 1], "omega2_init": x[..., 2],
            "omega3_init": x[..., 3], "E": e}


# one colour per code of solver.analysis.solution_types (0 undetermined grey, then Theorem 1's items 1-7)
TYPE_COLOURS = ("0.5", "tab:red", "tab:orange", "tab:purple", "tab:pink", "tab:green", "tab:blue", "tab:cyan")


def _types_plot(ds):
    codes = [int(v) for v in ds["type"].attrs["flag_values"]]
    names = ds["type"].attrs["flag_meanings"].split()
    counts = np.array([(ds["type"].values == c).sum() for c in codes])
    n = int(ds.sizes["sample"])
    frac = counts / n
    fig, ax = P.new_figure(7.5, 5.4)
    ypos = np.arange(len(codes))[::-1]
    ax.barh(ypos, frac, color=TYPE_COLOURS[:len(codes)], edgecolor="k", lw=0.6)
    for y, f, c in zip(ypos, frac, counts):
        inside = f > 0.75  # a long bar carries its number inside, so the axis stays a fraction in [0, 1]
        ax.text(f - 0.01 if inside else f + 0.01, y, f"{f:.1%} ({c})", va="center", fontsize=10,
                ha="right" if inside else "left", color="white" if inside else "k")
    ax.set_yticks(ypos, [f"{code} {nm.replace('_', ' ')}" for code, nm in zip(codes, names)])
    ax.set_xlim(0, 1)
    ax.set_xlabel(f"fraction of the {n} sampled states [-]")
    t_max = float(setting_of(ds, "t_max"))
    import textwrap

    words = "\n".join(textwrap.wrap(f"{_sample_words(ds)}; each followed for up to {t_max:g} s", 76))
    # over the figure, not the axes: the type names push the axes right, and a title centred on them ran
    # off the figure's right edge
    fig.suptitle(f"Types of solutions of the rolling equations (Theorem 1)\n{words}", fontsize=11)
    return fig


def _sample_words(ds) -> str:
    """How the states of a ``solution-types`` file were drawn, in words (seed for repeatability)."""
    subset, seed = setting_of(ds, "subset"), setting_of(ds, "seed")
    w = [float(setting_of(ds, f"omega{i}_max")) for i in (1, 2, 3)]
    words = {
        "box": rf"states drawn uniformly: $\beta$ in [$-\pi$, $\pi$), $|\omega_i| \leq$ "
               rf"{w[0]:g}, {w[1]:g}, {w[2]:g} 1/s",
        "pendulum_plane": rf"states drawn uniformly in the plane $\omega_2=\omega_3=0$ (Prop. 6), "
                          rf"$|\omega_1| \leq$ {w[0]:g} 1/s",
        "steady": rf"steady motions (47) with $|\omega_{{30}}| \leq$ {w[2]:g} 1/s, every fifth a trivial one (46)",
        "connections": rf"on stable manifolds of saddles (47), $|\omega_{{30}}| \leq$ {w[2]:g} 1/s, 1 in 5 of $x_0^+$",
        MIXED: "a quarter each: uniform in a box, the plane of Prop. 6, steady motions, near saddles' stable "
               "manifolds",
    }.get(str(subset), f"subset {subset}")
    return f"{words} (random seed {seed})"


# (atol, rtol) of `study verify` per variable of solution-types, from each one's conditioning: what
# round-off (another CPU's numpy sin/cos, another BLAS) can move it by, not the integrator's rtol.
# - omega1 of a state on a stable manifold is sqrt(2 (E* - U_P(beta)) / (m (1+j) r^2)): E* - U_P cancels
#   near the saddle, so an error eps |U_P| in the energies moves omega1 by eps |U_P| / (m (1+j) r^2
#   |omega1|): 5e-10 1/s at |omega1| = 5e-4 1/s (a halved offset, seen between two machines), up to
#   ~1e-8 1/s at the smallest offset sampled; the other components are closed forms of (beta, level).
_STATE_TOL = {"omega1_init": (1e-7, 1e-9)}
# - a time or angle read off a DOP853 solution (rtol 1e-10) of a state within 1e-8 of a saddle's level:
#   the time to pass the saddle grows as log(1 / distance) / lambda, so a relative change 1e-8 of the
#   state moves it by ~1e-8 / (lambda d) with d >= 1e-2 the fit window's top: <= 1e-6 s for lambda >= 1 1/s
_FLOW_TOL = {name: (1e-6, 1e-7) for name in ("half_period", "period", "t_first_zero", "alpha_advance")}
# - the approach rate is a least-squares slope of log(distance) over the dense-output samples between
#   two thresholds (solution_types.WINDOW_TOP and 10 x the closest approach): a sample entering or leaving
#   the window at round-off moves it by up to ~2e-3 of itself (seen: 1.85e-3 between two machines). The
#   classifier promises only |rate / lambda - 1| <= RATE_TOL, so two runs may differ by 2 RATE_TOL.
_FIT_TOL = {"approach_rate": (0.0, 2 * st.RATE_TOL)}
TYPES_TOLERANCES = {**_STATE_TOL, **_FLOW_TOL, **_FIT_TOL}
"""(atol, rtol) per continuous variable of solution-types whose conditioning is not that of a closed form
(those keep compare.DEFAULT_TOLERANCE, 1e-9): the equilibria, saddle_rate, E and the rational rotation tests
are closed forms of the state."""


register(Study(
    name="solution-types",
    title="Types of the solutions of the conservative rolling equations (Theorem 1, Table 2) over sampled states",
    settings={"n_samples": 400, "seed": 0, "subset": "box", "omega1_max": 20.0, "omega2_max": 70.0,
              "omega3_max": 70.0, "t_max": 20.0, "rtol": 1e-10, "atol": 1e-12},
    quick={"n_samples": 40, "t_max": 10.0, "subset": MIXED},  # a box's states are almost all periodic
    cost=4e-2, cost_scale="t_max", compiles=True,  # s per state at t_max 10 s (--quick), on one core
    axes=_types_axes,
    variables=with_tolerances([
        Var("type", "1", "type of the solution through the state: the item of Theorem 1, 0 if undetermined "
            "(docs/solution-types.md)", dtype="int8",
            flag_values=st.TYPE_FLAG_VALUES, flag_meanings=st.TYPE_FLAG_MEANINGS),
        Var("half_period", "s", "time t2 - t1 between two transversal zeros of omega1 "
            "(NaN unless periodic by Prop. 4)"),
        Var("period", "s", "period: 2 half_period, or q revolutions of beta for a rotation with rotation number p/q "
            "(NaN unless periodic)"),
        Var("t_first_zero", "s", "first zero of omega1 at or after t = 0 (NaN if none within t_max)"),
        Var("alpha_advance", "rad", "angle round the rim travelled in one period (NaN unless periodic)"),
        Var("rotation_number", "1", "turn of (omega2, omega3) per revolution of beta, in [0, 1/2] (rotations: "
            "periodic with rational, quasi_periodic with irrational value; NaN otherwise)"),
        Var("revolutions", "1", "revolutions of beta observed for a rotation: the largest denominator of the "
            "rational test (NaN otherwise)"),
        Var("beta_eq", "rad", "height angle of the unstable equilibrium a connection tends to (NaN otherwise)"),
        Var("omega2_eq", "s-1", "omega2 of the equilibrium a connection tends to (NaN otherwise)"),
        Var("omega3_eq", "s-1", "omega3 of the equilibrium a connection tends to (NaN otherwise)"),
        Var("saddle_rate", "s-1", "eigenvalue lambda of that equilibrium: sqrt(h) of (54), sqrt(g/(rho (1+j))) "
            "on top (NaN otherwise)"),
        Var("approach_rate", "s-1", "rate of the exponential approach measured along the solution (NaN otherwise)"),
        Var("connection", "1", "kind of connection (types 3 and 4)", dtype="int8",
            flag_values=st.CONNECTION_FLAG_VALUES, flag_meanings=st.CONNECTION_FLAG_MEANINGS),
        Var("beta_init", "rad", "initial height angle beta"),
        Var("omega1_init", "s-1", "initial angular velocity omega1"),
        Var("omega2_init", "s-1", "initial angular velocity omega2"),
        Var("omega3_init", "s-1", "initial angular velocity omega3"),
        Var("E", "J", "total energy (60) of the state (potential m g rho sin beta)"),
    ], TYPES_TOLERANCES),
    compute=_types_compute,
    plot=_types_plot,
    chunks={"sample": 20},
    # a regression reference at the study's own settings: the type of a state is decided by tests at
    # tolerances tied to rtol (a rotation number's rational test), so a tighter rtol is another
    # classifier, not a more precise answer; the default slice holds 40 of the 400 default states
    reference=ReferenceSpec({"sample": 40}, method="solution_types.classify (scipy DOP853 at the study's rtol)"),
))
