"""Parametric cubes: what the paper held fixed, swept (issue 5).

- ``realisable-cube``: the realisable steady motions of Fig. 8 over
  mu x v_throw x j x rho_over_R x beta0 x omega30, from ``solver.steady.realisable_region``;
  stores the region label of every point and, per (mu, v_throw, j, rho_over_R), the area of
  regions A, B and C in the (beta0, omega30) plane [rad s-1].
- ``outcome-cube``: outcomes of rolling initial states (Figs. 11-13 at reduced resolution) over
  mu x k_r x k_d x omega2 x beta x omega1, from ``solver.simulate``: outcome, t_end, revolutions.

Both are ordinary studies whose ``sweepable`` settings hold tuples by default; ``--set KEY=...``
changes the values (or a scalar removes the axis). One chunk = one outer point (whole grid).
"""

from __future__ import annotations

import numpy as np
from matplotlib.lines import Line2D

from rimroll import solver
from rimroll.solver.analysis import steady
from rimroll.study import plotting as P
from rimroll.study.dataset import setting_of
from rimroll.study.registry import Axis, Study, Var, output_var, register

STANDARD = solver.Params()
STANDARD_RHO_OVER_R = STANDARD.rho / STANDARD.R  # 0.5778: the ball of Table 1


def _cell_sizes(values: np.ndarray) -> np.ndarray:
    """Width of the cell around each grid point (uniform grids: the spacing)."""
    return np.abs(np.gradient(values)) if values.size > 1 else np.ones(1)


def _at_standard(da, keep):
    """Select the standard ball (j, rho/R of Table 1; nearest) along swept axes not in ``keep``."""
    for dim, value in (("j", STANDARD.j), ("rho_over_R", STANDARD_RHO_OVER_R)):
        if dim in da.dims and dim not in keep:
            da = da.sel({dim: value}, method="nearest")
    return da


def _ensure_dim(da, ds, name):
    """``da`` with a length-1 dimension ``name`` when the run held that setting scalar."""
    if name in da.dims:
        return da
    return da.expand_dims({name: [float(setting_of(ds, name))]})


# ================================================================ realisable-cube
def _realisable_axes(s: dict) -> list[Axis]:
    if s["n_beta0"] < 2 or s["n_omega30"] < 2 or not s["omega30_max"] > 0:
        raise ValueError("n_beta0 and n_omega30 must be >= 2 and omega30_max > 0")
    w = s["omega30_max"]
    return [Axis("beta0", np.linspace(-np.pi, np.pi, s["n_beta0"], endpoint=False), "rad",
                 "height angle of the steady motion on the rim's minor circle"),
            Axis("omega30", np.linspace(-w, w, s["n_omega30"]), "s-1",
                 "circular angular velocity of the steady motion")]


def _realisable_compute(coords, p, s):
    beta0, omega30 = coords
    region = steady.realisable_region(beta0, omega30, p, s["v_throw"])
    cells = np.outer(_cell_sizes(beta0[:, 0]), _cell_sizes(omega30[0, :]))
    areas = {f"area_{name}": float(cells[region == code].sum())
             for name, code in (("A", steady.REGION_A), ("B", steady.REGION_B), ("C", steady.REGION_C))}
    return {"region": region, **areas}


def mu_colours(mus) -> dict:
    """A colour per friction coefficient, in order of mu along a sequential colormap (viridis)."""
    from matplotlib import colormaps

    order = np.sort(np.unique(np.asarray(mus, dtype=float)))
    cmap = colormaps["viridis"]
    pos = np.linspace(0.0, 0.85, order.size) if order.size > 1 else np.array([0.4])
    return {float(m): cmap(x) for m, x in zip(order, pos)}


def _realisable_plot(ds):
    fig, axes = P.new_figure(13.5, 4.6)
    fig.clear()
    panels = fig.subplots(1, 3, sharey=False)
    colours = mu_colours(_ensure_dim(ds["area_A"], ds, "mu")["mu"].values)
    for ax, name in zip(panels, "ABC"):
        area = _ensure_dim(_ensure_dim(_at_standard(ds[f"area_{name}"], ()), ds, "v_throw"), ds, "mu")
        area = area.transpose("mu", "v_throw", ...).load()
        v = area["v_throw"].values
        for i in np.argsort(area["mu"].values):
            mu = float(area["mu"].values[i])
            values = area.isel(mu=i).values.reshape(v.size, -1)[:, 0]
            ax.plot(v, values, "o-", color=colours[mu], lw=1.5, ms=4, label=rf"$\mu$={mu:g}")
        ax.set_xlabel(r"$v_{throw}$ [m/s]")
        ax.set_ylabel(f"area of region {name} [rad/s]")
        ax.set_title(f"region {name}")
        ax.grid(alpha=0.3)
    panels[0].legend(loc="upper left", fontsize=9, title="friction", title_fontsize=9)
    ball = _at_standard(ds["area_A"], ())
    j = float(ball["j"]) if "j" in ball.coords else float(ds.attrs["param_j"])
    x = float(ball["rho_over_R"]) if "rho_over_R" in ball.coords else ds.attrs["param_rho"] / ds.attrs["param_R"]
    picked = [d for d in ("j", "rho_over_R") if d in ds["area_A"].dims]
    how = (" (the cube's nearest to the standard ball; choose with study plot FILE --select j=...)"
           if picked else "")
    fig.suptitle(rf"Realisable steady motions (Fig. 8) vs throw speed at j={j:.3g}, $\rho/R$={x:.3g}{how}",
                 fontsize=11)
    return fig


def _area(name):
    return Var(f"area_{name}", "rad s-1", f"area of realisable region {name} of Fig. 8 in the "
               "(beta0, omega30) plane", outer=True)


register(Study(
    name="realisable-cube",
    title="Realisable steady motions (Fig. 8) over mu x v_throw x j x rho/R, with areas of A, B, C",
    settings={"mu": (0.5, 1.0, 2.0), "v_throw": (1.0, 3.0, 5.0, 7.0, 10.0),
              "j": (0.4, 0.5333333333333333, 2.0 / 3.0), "rho_over_R": (0.45, STANDARD_RHO_OVER_R, 0.7),
              "n_beta0": 721, "n_omega30": 560, "omega30_max": 70.0},
    quick={"mu": (0.5, 1.0), "v_throw": (3.0, 7.0, 10.0), "j": (0.5, 2.0 / 3.0),
           "rho_over_R": (0.45, STANDARD_RHO_OVER_R), "n_beta0": 121, "n_omega30": 80},
    sweepable=("mu", "v_throw", "j", "rho_over_R"),
    cost=1e-6,  # seconds per grid point on one core, warm (--quick on 2 shared cores, 2026-11)
    axes=_realisable_axes,
    variables=[Var("region", "1", "region of the realisable steady motion (Fig. 8): stable (54), rolling "
                   "(56), within the throw energy (59)", dtype="int8",
                   flag_values=steady.REGION_FLAG_VALUES, flag_meanings=steady.REGION_FLAG_MEANINGS),
               _area("A"), _area("B"), _area("C")],
    compute=_realisable_compute,
    plot=_realisable_plot,
))


# ================================================================ outcome-cube
PALETTE = P.OUTCOME_PALETTE  # the one outcome palette (same colours and words as fig11-13)


def _outcome_axes(s: dict) -> list[Axis]:
    if s["n_beta"] < 2 or s["n_omega1"] < 2:
        raise ValueError(f"n_beta and n_omega1 must be >= 2; got {s['n_beta']}, {s['n_omega1']}")
    return [Axis("beta", np.linspace(0.8, 1.8, s["n_beta"]), "rad", "initial height angle on the rim"),
            Axis("omega1", np.linspace(-20.0, 20.0, s["n_omega1"]), "s-1", "initial angular velocity omega1")]


def _outcome_compute(coords, p, s):
    beta, omega1 = coords
    states = np.stack([beta, omega1, np.full_like(beta, s["omega2"]), np.full_like(beta, s["omega3"])], axis=-1)
    res = solver.simulate(states, p, t_max=s["t_max"], rtol=s["rtol"], atol=s["atol"], workers=1,
                          backend=s["backend"])
    return {name: res[name] for name in ("outcome", "t_end", "revolutions", "status")}


def _outcome_plot(ds):
    fig, _ = P.new_figure(12.5, 4.8)
    fig.clear()
    panels = fig.subplots(1, 2, sharey=True)
    outcome = ds["outcome"]
    for name in ("k_r", "k_d", "mu"):
        outcome = _ensure_dim(outcome, ds, name)
    grid = [d for d in outcome.dims if d not in ("mu", "k_r", "k_d")]  # omega2, beta, omega1, ...
    codes = [int(c) for c in np.unique(outcome.values)]  # the outcomes that occur: one curve each
    handles = []
    for ax, (along, other) in zip(panels, (("k_r", "k_d"), ("k_d", "k_r"))):
        cut = outcome.isel({other: 0})
        x = cut[along].values
        for i, mu in enumerate(cut["mu"].values):
            style = ("-", "--", ":", "-.")[i % 4]
            for code in codes:
                frac = (cut.isel(mu=i) == code).mean(grid).transpose(along).values
                ax.plot(x, frac, style, color=PALETTE.colour(code), marker="o", ms=4, lw=1.5)
                if along == "k_r" and i == 0:
                    handles.append(Line2D([], [], color=PALETTE.colour(code), lw=1.5, label=PALETTE.label(code)))
            if along == "k_r":
                handles.append(Line2D([], [], color="k", ls=style, label=rf"$\mu$={mu:g}"))
        other_txt = {"k_r": r"$k_r$", "k_d": r"$k_d$"}[other]
        ax.set_xlabel({"k_r": r"rolling resistance $k_r$ [1/s]", "k_d": r"drilling resistance $k_d$ [1/s]"}[along]
                      + f" (at {other_txt} = {float(cut[other]):g} 1/s)")
        ax.set_ylim(-0.02, 1.02)
        ax.grid(alpha=0.3)
    panels[0].set_ylabel("fraction of initial states")
    fig.legend(handles=handles, loc="outside right upper", fontsize=9)
    fig.suptitle(r"Outcome fractions over the ($\beta$, $\omega_1$) section"
                 + (r" and $\omega_2$" if "omega2" in grid else "") + ": dissipation (83) vs outcome")
    return fig


register(Study(
    name="outcome-cube",
    title="Outcomes of rolling initial states (Figs. 11-13, reduced grid) over mu x k_r x k_d x omega2",
    settings={"mu": (0.5, 1.0, 2.0), "k_r": (0.0, 0.01, 0.02), "k_d": (0.0, 0.01, 0.02),
              "omega2": (35.0, 65.0, 105.0), "omega3": 10.0, "n_beta": 36, "n_omega1": 60,
              "t_max": 20.0, "rtol": 1e-6, "atol": 1e-9, "backend": "cpu"},
    quick={"mu": (0.5, 1.0), "k_r": (0.0, 0.02), "k_d": (0.0, 0.02), "omega2": (65.0, 105.0),
           "n_beta": 12, "n_omega1": 18},
    sweepable=("mu", "k_r", "k_d", "omega2", "omega3", "j", "rho_over_R"),
    cost=2e-4, compiles=True,  # seconds per grid point on one core, warm (--quick on 2 shared cores, 2026-11)
    axes=_outcome_axes,
    variables=[output_var(name) for name in ("outcome", "t_end", "revolutions", "status")],
    compute=_outcome_compute,
    plot=_outcome_plot,
))
