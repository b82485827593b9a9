"""Floquet stability of omega2 = omega3 = 0 in (62) over (rho/R, j): paper Fig. 9 (Sect. 4.4, Prop. 7).

- ``fig9``: over the physically relevant parameters 0 < rho/R < 1 - a/R, 0 < j <= 2/3, whether
  both Floquet multipliers of (62) lie on the unit circle, with the trace of the monodromy matrix
  and the multipliers' moduli, from ``solver.floquet``.
"""

from __future__ import annotations

import numpy as np
from matplotlib.lines import Line2D
from matplotlib.patches import Patch

from rimroll import solver
from rimroll.solver.analysis import floquet
from rimroll.solver.physics.params import TERM_KEYS
from rimroll.study import plotting as P
from rimroll.study.dataset import setting_of
from rimroll.study.registry import Axis, ReferenceSpec, Study, Var, register


def _flag(name, long_name, meanings, values=None):
    values = tuple(range(len(meanings.split()))) if values is None else tuple(values)
    return Var(name, "1", long_name, dtype="int8", flag_values=values, flag_meanings=meanings)


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
