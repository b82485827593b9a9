"""Global dynamics of the rolling ball (paper Sect. 4): Fig. 9, the types of Theorem 1, invariants.

- ``fig9``: Floquet stability of omega2 = omega3 = 0 in (62) over the physically relevant
  parameters 0 < rho/R < 1 - a/R, 0 < j <= 2/3 (Prop. 7), from ``solver.floquet``.
- ``solution_types``: the type of Theorem 1 / Table 2 of seeded states sampled from a box of
  the phase space (beta, omega1, omega2, omega3), from ``solver.solution_types``.
- ``invariants``: relative change of E (60), P_I and P_II (65)-(68) along seeded trajectories
  of the conservative rolling equations near stable steady motions, from
  ``solver.trajectory`` and ``solver.invariants``.
"""

from __future__ import annotations

import numpy as np
from matplotlib.lines import Line2D
from matplotlib.patches import Patch

import solver
from solver import floquet
from study import plotting as P
from study.dataset import params_of, setting_of
from study.registry import Axis, Study, Var, register


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
    return [Axis("rho_over_R", x, "1", "ratio rho/R of the ball centre's distance from the rim's "
                 "middle circle to the rim's major radius"),
            Axis("j", j, "1", "dimensionless moment of inertia of the ball, J = j m r^2")]


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
    ax.contourf(x, j, stable, levels=[0.5, 1.5], colors=["0.72"])
    ax.contour(x, j, np.abs(tr), levels=[2.0], colors="k", linewidths=1.2)
    P.label_parts(ax, x, j, stable == 1, "S", min_fraction=0.004, fontsize=16)
    P.label_parts(ax, x, j, stable == 0, "U", min_fraction=0.004, fontsize=16)
    # boundary of the physically relevant range (striped, as in the paper)
    y_top = 0.75
    ax.add_patch(_hatched((x_max, 0.0), 1.0 - x_max, y_top))
    ax.add_patch(_hatched((0.0, J_MAX), 1.0, y_top - J_MAX))
    ax.axvline(x_max, color="k", lw=1.0)
    ax.axhline(J_MAX, color="k", lw=1.0)
    std = solver.Params()
    ax.plot([std.rho / std.R], [std.j], "o", ms=11, mfc="none", mec="tab:red", mew=2.2, zorder=8)
    ax.annotate("standard ball\n(Table 1)", (std.rho / std.R, std.j), xytext=(-14, -34),
                textcoords="offset points", ha="right", va="top", fontsize=10, color="tab:red",
                bbox=dict(fc="white", ec="none", alpha=0.8),
                arrowprops=dict(arrowstyle="-", color="tab:red", lw=1.0))
    ax.set_xlim(0.0, 1.0)
    ax.set_ylim(0.0, y_top)
    ax.set_xlabel(r"$\rho/R$ [-]")
    ax.set_ylabel(r"$j$ [-]  ($J = j\,m\,r^2$)")
    ax.set_title(r"Floquet stability of $\omega_2=\omega_3=0$ in (62): S stable ($|\mu_{1,2}|=1$), "
                 r"U unstable", fontsize=11)
    handles = [Patch(fc="0.72", label=r"S: $|\mathrm{tr}\,M| \leq 2$, quasi-periodic"),
               Patch(fc="white", ec="0.5", label=r"U: $|\mu_1| < 1 < |\mu_2|$"),
               Patch(fc="white", ec="0.3", hatch="///", label=r"outside $0<\rho/R<1-a/R$, $0<j\leq 2/3$"),
               Line2D([], [], ls="none", marker="o", ms=9, mfc="none", mec="tab:red", mew=2,
                      label=rf"standard ball $\rho/R$={std.rho / std.R:.3f}, $j$={std.j:.3f}")]
    fig.legend(handles=handles, loc="outside lower center", ncol=2, fontsize=9, frameon=False)
    return fig


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
))
