"""Global dynamics of the rolling ball (paper Sect. 4): Fig. 9, the types of Theorem 1, invariants.

- ``fig9``: Floquet stability of omega2 = omega3 = 0 in (62) over the physically relevant
  parameters 0 < rho/R < 1 - a/R, 0 < j <= 2/3 (Prop. 7), from ``solver.floquet``.
- ``solution_types``: the type of Theorem 1 / Table 2 of seeded states sampled from a box of
  the phase space (beta, omega1, omega2, omega3), from ``solver.analysis.solution_types``.
- ``invariants``: relative change of E (60), P_I and P_II (65)-(68) along seeded trajectories
  of the conservative rolling equations near stable steady motions, from
  ``solver.analysis.trajectory`` and ``solver.invariants``.
"""

from __future__ import annotations

import numpy as np
from matplotlib.lines import Line2D
from matplotlib.patches import Patch

from rimroll import solver
from rimroll.solver.analysis import floquet, reduced, steady, trajectory
from rimroll.solver.analysis import solution_types as st
from rimroll.solver.physics.params import DISSIPATION_KEYS, TERM_KEYS
from rimroll.study import plotting as P
from rimroll.study.dataset import setting_of
from rimroll.study.registry import Axis, ReferenceSpec, Study, Var, register, with_tolerances


def _flag(name, long_name, meanings, values=None):
    values = tuple(range(len(meanings.split()))) if values is None else tuple(values)
    return Var(name, "1", long_name, dtype="int8", flag_values=values, flag_meanings=meanings)


# ================================================================ Fig. 9: Floquet stability map
J_MAX = 2.0 / 3.0  # thin spherical shell: the largest j of a ball with its mass at radius <= r


def _fig9_axes(s: dict) -> list[Axis]:
    n_x, n_j = int(s["n_rho_over_R"]), int(s["n_j"])
    if n_x < 2 or n_j < 2:
        raise ValueError(f"n_rho_over_R and n_j must be >= 2; got {n_x}, {n_j}")
    x_max = 1.0 - s["a"] / s["R"]
    if not 0 < x_max < 1:
        raise ValueError(f"1 - a/R = {x_max:g} must lie in (0, 1)")
    # cell centres in (0, 1 - a/R): both ends are excluded by Prop. 7; j in (0, 2/3] ends at 2/3
    x = (np.arange(n_x) + 0.5) / n_x * x_max
    j = (np.arange(n_j) + 1.0) / n_j * J_MAX
    return [Axis("rho_over_R", x, "1", "ratio rho/R", comment="ratio rho/R of the ball centre's distance from "
                 "the rim's middle circle to the rim's major radius"),
            Axis("j", j, "1", "inertia factor j", comment="dimensionless moment of inertia of the ball, J = j m r^2")]


def _fig9_compute(coords, p, s):
    x, j = coords
    tr = floquet.trace(x, j)
    mu = floquet.multipliers_from_trace(tr)
    return {"stable": (np.abs(tr) <= 2.0).astype(np.int8), "trace_M": tr,
            "abs_mu1": np.abs(mu[..., 0]), "abs_mu2": np.abs(mu[..., 1])}


def _fig9_plot(ds):
    x = ds["rho_over_R"].values
    j = ds["j"].values
    stable = ds["stable"].transpose("j", "rho_over_R").values
    tr = ds["trace_M"].transpose("j", "rho_over_R").values
    x_max = 1.0 - float(setting_of(ds, "a")) / float(setting_of(ds, "R"))
    fig, ax = P.new_figure(7.5, 6.4)
    # the grid holds cell centres: its values are carried to the domain's edges (rho/R = 0 and 1 - a/R,
    # j = 0), so that the shading reaches the axes and a strip along them does not read as unstable
    xl, jl = P.grid_limits(x), P.grid_limits(j)
    full = xl[0] <= 0.05 * x_max and xl[1] >= 0.95 * x_max and jl[0] <= 0.05 * J_MAX and jl[1] >= 0.95 * J_MAX
    xs, js, trs = _to_edges(x, j, np.abs(tr), (0.0, x_max), (0.0, J_MAX)) if full else (x, j, np.abs(tr))
    ax.contourf(xs, js, trs, levels=[0.0, 2.0], colors=["0.72"])  # = stable, drawn smoothly
    ax.contour(xs, js, trs, levels=[2.0], colors="k", linewidths=1.2)
    if min(x.size, j.size) >= 5:  # on a grid of a few points every part touches the edge: the legend says it
        P.label_parts(ax, x, j, stable == 1, "S", min_fraction=0.004, fontsize=16)
        P.label_parts(ax, x, j, stable == 0, "U", min_fraction=0.004, fontsize=16)
    # the computed domain; when it is the whole physical range, the paper's view with the
    # outside of the range striped, else the computed domain only (nothing uncomputed drawn)
    y_top = 0.75
    if full:
        ax.add_patch(_hatched((x_max, 0.0), 1.0 - x_max, y_top))
        ax.add_patch(_hatched((0.0, J_MAX), 1.0, y_top - J_MAX))
        ax.axvline(x_max, color="k", lw=1.0)
        ax.axhline(J_MAX, color="k", lw=1.0)
    std = solver.Params()
    std_shown = full or (x.min() <= std.rho / std.R <= x.max() and j.min() <= std.j <= j.max())
    # the standard ball is a thin shell, j = 2/3: on the edge of the physical range, drawn filled above
    # the hatching so that neither hides the other
    ax.plot([std.rho / std.R], [std.j], "o", ms=10, mfc="white", mec="tab:red", mew=2.4, zorder=9)
    ax.plot([std.rho / std.R], [std.j], "o", ms=3.5, color="tab:red", zorder=10)
    if std_shown:
        ax.annotate("standard ball (Table 1):\na thin shell, j = 2/3", (std.rho / std.R, std.j), xytext=(24, -40),
                    textcoords="offset points", ha="left", va="top", fontsize=10, color="tab:red",
                    bbox=dict(fc="white", ec="none", alpha=0.8),
                    arrowprops=dict(arrowstyle="-", color="tab:red", lw=1.0))
    if full:
        ax.set_xlim(0.0, 1.0)
        ax.set_ylim(0.0, y_top)
    else:
        ax.set_xlim(x.min(), x.max())
        ax.set_ylim(j.min(), j.max())
    ax.set_xlabel(r"$\rho/R$ [-]")
    ax.set_ylabel(r"$j$ [-]  ($J = j\,m\,r^2$)")
    ax.set_title(r"Floquet stability of $\omega_2=\omega_3=0$ in (62): S stable ($|\mu_{1,2}|=1$), "
                 r"U unstable", fontsize=11)
    handles = [Patch(fc="0.72", label=r"S: $|\mathrm{tr}\,M| \leq 2$, quasi-periodic"),
               Patch(fc="white", ec="0.5", label=r"U: $|\mu_1| < 1 < |\mu_2|$"),
               Line2D([], [], ls="none", marker="o", ms=9, mfc="white", mec="tab:red", mew=2,
                      label=rf"standard ball $\rho/R$={std.rho / std.R:.3f}, $j$={std.j:.3f}")][: 3 if std_shown else 2]
    if full:
        handles.insert(2, Patch(fc="white", ec="0.3", hatch="///", label=r"outside $0<\rho/R<1-a/R$, $0<j\leq 2/3$"))
    fig.legend(handles=handles, loc="outside lower center", ncol=2, fontsize=9, frameon=False)
    return fig


def _to_edges(x, y, values, x_edges, y_edges):
    """The grid (x, y) and ``values`` (y, x) extended by the nearest values to the domain's edges
    ``x_edges``, ``y_edges`` where the grid's first or last point lies inside them (cell centres)."""
    if x_edges[0] < x[0]:
        x, values = np.concatenate([[x_edges[0]], x]), np.concatenate([values[:, :1], values], axis=1)
    if x_edges[1] > x[-1]:
        x, values = np.concatenate([x, [x_edges[1]]]), np.concatenate([values, values[:, -1:]], axis=1)
    if y_edges[0] < y[0]:
        y, values = np.concatenate([[y_edges[0]], y]), np.concatenate([values[:1], values], axis=0)
    if y_edges[1] > y[-1]:
        y, values = np.concatenate([y, [y_edges[1]]]), np.concatenate([values, values[-1:]], axis=0)
    return x, y, values


def _hatched(xy, width, height):
    from matplotlib.patches import Rectangle

    return Rectangle(xy, width, height, fc="white", ec="0.3", hatch="///", lw=0.0, zorder=3)


register(Study(
    name="fig9",
    title="Floquet stability of omega2 = omega3 = 0 in (62) over (rho/R, j) (paper Fig. 9, Prop. 7)",
    settings={"n_rho_over_R": 200, "n_j": 200},
    quick={"n_rho_over_R": 40, "n_j": 30},
    axes=_fig9_axes,
    variables=[
        _flag("stable", "neutrally stable (both Floquet multipliers of (62) on the unit circle, "
              "|tr M| <= 2)", "unstable stable"),
        Var("trace_M", "1", "trace of the monodromy matrix M of (62) over beta in [0, 2 pi]"),
        Var("abs_mu1", "1", "modulus of the smaller Floquet multiplier of (62)"),
        Var("abs_mu2", "1", "modulus of the larger Floquet multiplier of (62)"),
    ],
    compute=_fig9_compute,
    plot=_fig9_plot,
    chunks={"rho_over_R": 50},
    ignores={"mu": "the Floquet problem (62) is about rolling, without friction limits",
             **{k: "the Floquet problem (62) is conservative" for k in TERM_KEYS},
             "j": "j is an axis of the map (give a list or range to change its values)"},
    cost=1.5e-4,  # seconds per grid point on one core, warm (--quick on 2 shared cores, 2026-11)
    reference=ReferenceSpec({"rho_over_R": 40, "j": 30},
                            method="solver.floquet fixed-step RK8 in theta (~1e-13 relative in tr M)"),
))


# ================================================================ Theorem 1: types of solutions
SUBSETS = ("box", "pendulum_plane", "steady", "connections")
MIXED = "mixed"  # the four subsets in turn: every type of Theorem 1 in one sample (the --quick run)


def _conservative(s: dict) -> None:
    on = {k: s[k] for k in DISSIPATION_KEYS if s[k] != 0}
    if on:
        raise ValueError("Theorem 1 is about the conservative rolling equations: need "
                         + " = ".join(DISSIPATION_KEYS) + " = 0; got " + ", ".join(f"{k}={v}" for k, v in on.items()))


def _types_axes(s: dict) -> list[Axis]:
    _conservative(s)
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


# ================================================================ conserved quantities E, P_I, P_II
def _inv_axes(s: dict) -> list[Axis]:
    _conservative(s)
    n, n_t = int(s["n_trajectories"]), int(s["n_time"])
    if n < 2 or n_t < 2 or not s["t_max"] > 0:
        raise ValueError(f"n_trajectories and n_time must be >= 2 and t_max > 0; got {n}, {n_t}, {s['t_max']}")
    return [Axis("trajectory", np.arange(n, dtype=float), "1", "trajectory index",
                 comment="index of the seeded trajectory"),
            # "t", not "time": CF reads a dimension named time as a calendar time (units "s since ...")
            Axis("t", np.linspace(0.0, s["t_max"], n_t), "s", "time")]


def initial_states(s: dict, p) -> np.ndarray:
    """Seeded initial states (n_trajectories, 4) near stable steady motions of region A.

    beta0 uniform in [beta0_min, beta0_max], omega30 = s["omega30"], omega20 from (48), then
    omega1 = uniform in [-d_omega1, d_omega1] added to the steady motion's omega1 = 0.
    """
    n = int(s["n_trajectories"])
    rng = np.random.default_rng(int(s["seed"]))
    beta0 = rng.uniform(s["beta0_min"], s["beta0_max"], n)
    x = steady.steady_state(beta0, np.full(n, float(s["omega30"])), p)
    x[:, 1] += rng.uniform(-1, 1, n) * s["d_omega1"]
    return x


def _inv_compute(coords, p, s):
    k, t = coords
    x0 = initial_states(s, p)
    out = {name: np.empty(k.shape) for name in ("E", "P_I", "P_II", "beta", "omega1")}
    for row in range(k.shape[0]):
        traj = trajectory.rolling_trajectory(x0[int(k[row, 0])], p, t[row], rtol=s["rtol"], atol=s["atol"])
        q = solver.invariants(traj, p)
        for name in ("E", "P_I", "P_II"):
            out[name][row] = q[name]
        out["beta"][row] = traj[:, 0]
        out["omega1"][row] = traj[:, 1]
    q0 = solver.invariants(x0[k[:, 0].astype(int)], p)
    p_norm = np.hypot(q0["P_I"], q0["P_II"])[:, None]
    return {"rel_change_E": (out["E"] - q0["E"][:, None]) / np.abs(q0["E"])[:, None],
            "rel_change_P_I": (out["P_I"] - q0["P_I"][:, None]) / p_norm,
            "rel_change_P_II": (out["P_II"] - q0["P_II"][:, None]) / p_norm,
            "E": out["E"], "P_I": out["P_I"], "P_II": out["P_II"],
            "beta_t": out["beta"], "omega1_t": out["omega1"]}


def _inv_plot(ds):
    from matplotlib.figure import Figure

    fig = Figure(figsize=(8.0, 7.0), layout="constrained")
    axes = fig.subplots(3, 1, sharex=True)
    t = ds["t"].values
    rtol = float(setting_of(ds, "rtol"))
    tiny = 1e-17
    labels = (r"$|\Delta E|/|E_0|$ [-]", r"$|\Delta P_I|/|P_0|$ [-]", r"$|\Delta P_{II}|/|P_0|$ [-]")
    for ax, name, label in zip(axes, ("rel_change_E", "rel_change_P_I", "rel_change_P_II"), labels):
        for k in ds["trajectory"].values:
            v = np.abs(ds[name].sel(trajectory=k).values)
            ax.semilogy(t[1:], np.maximum(v[1:], tiny), lw=1.0, label=state_label(ds.sel(trajectory=k)))
        ax.axhline(rtol, color="k", ls="--", lw=1.0)
        ax.text(t[-1], rtol, " rtol", va="bottom", ha="right", fontsize=9)
        ax.set_ylabel(label)
        ax.set_ylim(tiny, max(1e-6, 10 * rtol))
        ax.grid(True, which="major", alpha=0.3)
    axes[-1].set_xlabel("time $t$ [s]")
    axes[0].set_title(rf"Conserved quantities along rolling trajectories near steady motions "
                      rf"($\omega_{{30}}$ = {float(setting_of(ds, 'omega30')):g} 1/s)" "\n"
                      rf"DOP853 rtol = {rtol:g}; "
                      r"$|P_0| = |(P_I, P_{II})(0)|$", fontsize=10)
    if ds.sizes["trajectory"] <= 8:
        handles, labels = axes[0].get_legend_handles_labels()
        fig.legend(handles, labels, loc="outside lower center", ncol=3, fontsize=8, frameon=False,
                   title=r"initial state: a steady motion (48) with $\omega_1$ perturbed", title_fontsize=8)
    return fig


def state_label(sel) -> str:
    """The initial state of one trajectory of an ``invariants`` file, in words a reader can use."""
    b = float(sel["beta_t"].isel(t=0))
    w1 = float(sel["omega1_t"].isel(t=0))
    return rf"$\beta_0$={b:.3f} rad, $\omega_1$={w1:+.3f} 1/s"


register(Study(
    name="invariants",
    title="Conservation of E (60), P_I and P_II (65)-(68) along rolling trajectories (paper Sect. 4.4)",
    settings={"n_trajectories": 6, "seed": 1, "beta0_min": 0.3, "beta0_max": 1.2, "omega30": 10.0,
              "d_omega1": 0.5, "t_max": 20.0, "n_time": 401, "rtol": 1e-10, "atol": 1e-12},
    quick={"n_trajectories": 3, "t_max": 5.0, "n_time": 101},
    cost=2e-3, cost_scale="t_max", compiles=True,  # s per point at t_max 5 s (--quick), on one core
    axes=_inv_axes,
    variables=[
        Var("rel_change_E", "1", "relative change of the energy (60), (E(t) - E(0))/|E(0)|"),
        Var("rel_change_P_I", "1", "change of P_I (68) relative to |(P_I, P_II)| at t = 0"),
        Var("rel_change_P_II", "1", "change of P_II (68) relative to |(P_I, P_II)| at t = 0"),
        Var("E", "J", "total energy (60) (potential m g rho sin beta)"),
        Var("P_I", "s-1", "conserved quantity P_I (68), c_I = (1, 0)"),
        Var("P_II", "s-1", "conserved quantity P_II (68), c_II = (0, 1)"),
        Var("beta_t", "rad", "height angle beta along the trajectory"),
        Var("omega1_t", "s-1", "angular velocity omega1 along the trajectory"),
    ],
    compute=_inv_compute,
    plot=_inv_plot,
    chunks={"trajectory": 1},
    # scipy DOP853 at rtol 1e-12 against the default 1e-10, every 10th output time of the default grid
    reference=ReferenceSpec({"trajectory": 6, "t": 41}, precise=("rtol=1e-12", "atol=1e-14"),
                            method="scipy DOP853 (solver.analysis.trajectory)"),
))
