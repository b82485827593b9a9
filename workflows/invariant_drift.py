"""Invariants of the conservative rolling equations (paper Sect. 4, Props. 9-10) along trajectories.

- ``invariants``: relative change of E (60), P_I and P_II (65)-(68) along seeded trajectories of
  the conservative rolling equations near stable steady motions, from
  ``solver.analysis.trajectory`` and ``solver.invariants``.
"""

from __future__ import annotations

import numpy as np

from rimroll import solver
from rimroll.solver.analysis import steady, trajectory
from rimroll.study import checks
from rimroll.study.dataset import setting_of
from rimroll.study.registry import Axis, ReferenceSpec, Study, Var, register


def _inv_axes(s: dict) -> list[Axis]:
    checks.require_conservative(s, "E, P_I and P_II are invariants of the conservative rolling equations")
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
    reference=ReferenceSpec({"trajectory": 6, "t": 41}, precise={"rtol": 1e-12, "atol": 1e-14},
                            method="scipy DOP853 (solver.analysis.trajectory)"),
))
