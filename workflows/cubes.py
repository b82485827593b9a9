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

import solver
from solver import outcomes, steady
from study import plotting as P
from study.dataset import setting_of
from study.registry import Axis, Study, Var, register

STANDARD = solver.Params()
STANDARD_RHO_OVER_R = STANDARD.rho / STANDARD.R  # 0.5778: the ball of Table 1
MU_COLOURS = ("tab:purple", "tab:blue", "tab:green", "tab:orange", "tab:red", "k")


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


def _realisable_plot(ds):
    fig, axes = P.new_figure(13.5, 4.6)
    fig.clear()
    panels = fig.subplots(1, 3, sharey=False)
    handles = []
    for ax, name in zip(panels, "ABC"):
        area = _ensure_dim(_ensure_dim(_at_standard(ds[f"area_{name}"], ()), ds, "v_throw"), ds, "mu")
        area = area.transpose("mu", "v_throw", ...).load()
        v = area["v_throw"].values
        for i, mu in enumerate(area["mu"].values):
            colour = MU_COLOURS[i % len(MU_COLOURS)]
            values = area.isel(mu=i).values.reshape(v.size, -1)[:, 0]
            ax.plot(v, values, "o-", color=colour, lw=1.5, ms=4)
            if name == "A":
                handles.append(Line2D([], [], color=colour, marker="o", label=rf"$\mu$={mu:g}"))
        ax.set_xlabel(r"$v_{throw}$ [m/s]")
        ax.set_ylabel(f"area of region {name} [rad/s]")
        ax.set_title(f"region {name}")
        ax.grid(alpha=0.3)
    fig.legend(handles=handles, loc="outside right upper", fontsize=9)
    fig.suptitle(r"Realisable steady motions (Fig. 8) vs throw speed, standard ball "
                 rf"(j={STANDARD.j:.3g}, $\rho/R$={STANDARD_RHO_OVER_R:.3g}; nearest in the cube)")
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
    axes=_realisable_axes,
    variables=[Var("region", "1", "region of the realisable steady motion (Fig. 8): stable (54), rolling "
                   "(56), within the throw energy (59)", dtype="int8",
                   flag_values=steady.REGION_FLAG_VALUES, flag_meanings=steady.REGION_FLAG_MEANINGS),
               _area("A"), _area("B"), _area("C")],
    compute=_realisable_compute,
    plot=_realisable_plot,
))
