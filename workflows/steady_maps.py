"""Maps of the steady motions over (beta0, omega30): paper Figs. 3, 5, 6, 7 and 8 (Sect. 3).

Each study sweeps the height angle beta0 in [-pi, pi) [rad] and the circular angular velocity
omega30 in [-omega30_max, omega30_max] [1/s] and calls ``solver.steady``. The default grids
(721 x 560) avoid the singular lines beta0 = +-pi/2 and omega30 = 0 of (48): 721 is not a
multiple of 4 and an even number of omega30 points straddles 0.
"""

from __future__ import annotations

import numpy as np
from matplotlib.lines import Line2D
from matplotlib.patches import Patch

from rimroll.solver.analysis import steady
from rimroll.solver.physics.params import TERM_KEYS
from rimroll.study import plotting as P
from rimroll.study.dataset import params_of, setting_of
from rimroll.study.registry import Axis, ReferenceSpec, Study, Var, register

GRID = {"n_beta0": 721, "n_omega30": 560, "omega30_max": 70.0}
QUICK = {"n_beta0": 121, "n_omega30": 80}
CHUNKS = {"beta0": 61}
REFERENCE = ReferenceSpec({"beta0": 121, "omega30": 80})  # slices: a 121 x 80 sub-grid of the default grid
MU_LEVELS = (0.25, 0.5, 1.0, 2.0)
MU_COLOURS = ("tab:purple", "tab:blue", "tab:green", "tab:orange")
V_LEVELS = (1.0, 3.0, 5.0, 7.0, 10.0)
V_COLOURS = ("tab:purple", "tab:blue", "tab:green", "tab:orange", "k")
ZONES = {"I": np.pi / 4, "II": 3 * np.pi / 4, "III": -3 * np.pi / 4, "IV": -np.pi / 4}  # Fig. 4


def _axes(s: dict) -> list[Axis]:
    if s["n_beta0"] < 2 or s["n_omega30"] < 2 or not s["omega30_max"] > 0:
        raise ValueError("n_beta0 and n_omega30 must be >= 2 and omega30_max > 0; got "
                         f"{s['n_beta0']}, {s['n_omega30']}, {s['omega30_max']}")
    w = s["omega30_max"]
    return [
        Axis("beta0", np.linspace(-np.pi, np.pi, s["n_beta0"], endpoint=False), "rad", "steady height angle",
             comment="height angle of the steady motion on the rim's minor circle"),
        Axis("omega30", np.linspace(-w, w, s["n_omega30"]), "s-1", "steady omega3",
             comment="circular angular velocity of the steady motion"),
    ]


def _study(name, title, variables, compute, plot, cost, **settings) -> Study:
    """Register one map; ``cost``: seconds per grid point on one core, warm (measured with --quick
    on 2 shared cores, 2026-11)."""
    # steady motions of the conservative rolling equations: no dissipation; friction only where declared
    ignores = {k: "steady motions of the conservative rolling equations do not depend on dissipation"
               for k in TERM_KEYS}
    if "mu" not in settings:
        ignores["mu"] = "this map of the steady rolling motions does not depend on friction"
    return register(Study(name=name, title=title, settings={**GRID, **settings}, quick=QUICK,
                          axes=_axes, variables=variables, compute=compute, plot=plot, chunks=CHUNKS,
                          ignores=ignores, cost=cost, reference=REFERENCE))


def _flag(name, long_name, meanings):
    return Var(name, "1", long_name, dtype="int8", flag_values=tuple(range(len(meanings.split()))),
               flag_meanings=meanings)


OMEGA20 = Var("omega20", "s-1", "orthogonal angular velocity of the steady motion (48)")


# ---------------------------------------------------------------- Fig. 3: omega20 (48)
def _fig3_compute(coords, p, s):
    return {"omega20": steady.omega20(*coords, p)}


def _fig3_plot(ds):
    from matplotlib.colors import SymLogNorm

    fig, ax = P.new_figure()
    b, w, v = P.plane(ds, "omega20")
    mesh = ax.pcolormesh(b, w, v, shading="nearest", cmap="RdBu_r", rasterized=True,
                         norm=SymLogNorm(linthresh=1.0, vmin=-1e3, vmax=1e3))
    fig.colorbar(mesh, ax=ax, label=r"$\omega_{20}$ [1/s] (symmetric log scale)")
    # omega20 = 0; huge values masked so the sign jumps across the singular lines draw nothing
    ax.contour(b, w, np.where(np.abs(v) < 100.0, v, np.nan), levels=[0.0], colors="k", linestyles=":",
               linewidths=1.2)
    P.singular_lines(ax)
    top = w.max() * 0.88
    for text, x in ZONES.items():
        if not b.min() <= x <= b.max():  # a restricted grid: only the zones it computed
            continue
        ax.text(x, top, text, ha="center", va="center", fontsize=14, fontweight="bold",
                bbox=dict(fc="white", ec="none", alpha=0.8))
    P.beta_omega_axes(ax, ds, r"Steady motions (48): $\omega_{20}(\beta_0, \omega_{30})$; "
                              r"dotted: $\omega_{20}=0$")
    return fig


_study("fig3", "Steady motions: omega20 of (48) over (beta0, omega30) (paper Fig. 3)",
       [OMEGA20], _fig3_compute, _fig3_plot, 1e-7)


# ---------------------------------------------------------------- Fig. 5: stability h (54)
def _fig5_compute(coords, p, s):
    h = steady.stability(*coords, p)
    with np.errstate(invalid="ignore"):
        return {"h": h, "stable": (h < 0).astype(np.int8)}


def _beta_hat_points(p, w_max):
    """(beta_hat, omega30) points where the stable region reaches min |beta0|: h's maximum
    over omega30 at beta_hat touches 0 from below there (computed, not typed)."""
    bh = steady.beta_hat(p)
    w = np.linspace(0.05, w_max, 20001)
    w_tip = w[np.argmin(np.abs(steady.stability(bh, w, p)))]
    return bh, np.array([-w_tip, w_tip])


def _fig5_plot(ds):
    p = params_of(ds)
    fig, ax = P.new_figure()
    b, w, stable = P.plane(ds, "stable")
    _, _, h = P.plane(ds, "h")  # shade from h itself, not the 0/1 mask, for smooth boundaries
    ax.contourf(b, w, h, levels=[np.nanmin(h) - 1.0, 0.0], colors=["0.72"])  # smooth edge: h < 0
    ax.contour(b, w, h, levels=[0.0], colors="k", linewidths=1.0)
    P.label_parts(ax, b, w, stable == 1, "S", min_fraction=0.01, split=True)
    P.label_parts(ax, b, w, stable == 0, "U", min_fraction=0.01, split=True)
    marks = []  # beta* and beta_hat exist only for R > (1+j) rho (another --set j or r: the map alone)
    try:
        bs = steady.beta_star(p)
    except ValueError:
        bs = None
    if bs is not None:
        for x in (-bs, bs):
            ax.axvline(x, color="tab:red", ls="--", lw=1.2)
        for x, text, ha in ((bs, r" $\beta^*$", "left"), (-bs, r"$-\beta^*$ ", "right")):
            if b.min() <= x <= b.max():
                ax.text(x, w.max() * 0.93, text, color="tab:red", fontsize=12, ha=ha)
        marks.append(rf"$\beta^*$={bs:.3f}")
    try:
        bh, w_tip = _beta_hat_points(p, float(np.abs(w).max()))
    except ValueError:
        bh = None
    if bh is not None:
        ax.plot([bh, bh], w_tip, "o", color="k", ms=6, zorder=8)
        ax.annotate(r"$\hat\beta$", (bh, w_tip[1]), xytext=(8, 6), textcoords="offset points", fontsize=12)
        marks.append(rf"$\hat\beta$={bh:.3f} rad")
    P.singular_lines(ax, circles=False)
    P.beta_omega_axes(ax, ds, r"Stability (54): shaded S = neutrally stable ($h<0$), U = unstable"
                              + "".join(f"; {m}" for m in marks[:1]) + "".join(f", {m}" for m in marks[1:]))
    return fig


_study("fig5", "Stability of the steady motions: h of (54) (paper Fig. 5)",
       [Var("h", "s-2", "squared non-zero eigenvalue of the linearised rolling equations (54)"),
        _flag("stable", "neutrally stable steady motion (h < 0)", "unstable neutrally_stable")],
       _fig5_compute, _fig5_plot, 1e-7)


# ---------------------------------------------------------------- Fig. 6: slipping and falling
def _fig6_compute(coords, p, s):
    _, F2, _ = steady.contact_forces(*coords, p)
    return {"required_friction": steady.required_friction(*coords, p), "F2": F2,
            "rolls": steady.rolls_without_slipping(*coords, p).astype(np.int8)}


def _fig6_plot(ds):
    p = params_of(ds)
    fig, ax = P.new_figure()
    b, w, mu_req = P.plane(ds, "required_friction")
    _, _, F2 = P.plane(ds, "F2")
    finite = np.where(np.isfinite(mu_req), mu_req, 1e6)
    ax.contourf(b, w, finite, levels=[-1.0, min(p.mu, 1e5)], colors=["0.78"])  # rolls: required mu <= mu
    handles = [Patch(fc="0.78", label=rf"rolls at $\mu$={p.mu:g}")]
    for level, colour in zip(MU_LEVELS, MU_COLOURS):
        ax.contour(b, w, finite, levels=[level], colors=[colour], linewidths=1.4)
        handles.append(Line2D([], [], color=colour, lw=1.4, label=rf"$\mu$={level:g}"))
    ax.contour(b, w, F2, levels=[0.0], colors="k", linewidths=2.0, linestyles="-.")
    handles.append(Line2D([], [], color="k", lw=2.0, ls="-.", label=r"$\mu=\infty$: $F_2=0$ (57)"))
    bt = float(np.arctan(p.mu))
    for x in (np.pi / 2 - bt, np.pi / 2 + bt, -bt, bt):
        ax.axvline(x, color="tab:red", ls="--", lw=0.9)
    handles.append(Line2D([], [], color="tab:red", lw=0.9, ls="--",
                          label=r"$\pm\tilde\beta$, $\pi/2\pm\tilde\beta$"))
    fig.legend(handles=handles, loc="outside right upper", fontsize=9, title="boundaries (56)")
    P.singular_lines(ax, circles=False)
    P.beta_omega_axes(ax, ds, rf"Slipping (56) and falling (57); $\tilde\beta=\arctan\mu$={bt:.3f} rad")
    return fig


_study("fig6", "Slipping and falling limits of the steady motions (paper Fig. 6)",
       [Var("required_friction", "1", "smallest friction coefficient keeping the steady motion rolling "
            "(56); inf where the ball falls (57)"),
        Var("F2", "N", "normal contact force of the steady motion (31)"),
        _flag("rolls", "steady motion rolls without slipping at friction mu (56)", "slips_or_falls rolls")],
       _fig6_compute, _fig6_plot, 2e-6, mu=1.0)


# ---------------------------------------------------------------- Fig. 7: kinetic energy (59)
def _fig7_compute(coords, p, s):
    v = steady.throw_speed(*coords, p)
    return {"throw_speed": v, "within": (v <= s["v_throw"]).astype(np.int8)}


def _fig7_plot(ds):
    v_throw = float(setting_of(ds, "v_throw"))
    p = params_of(ds)
    fig, ax = P.new_figure()
    # (59) is a closed form of (beta0, omega30): its contours are drawn from a finer grid than the
    # file's, so that the small 1 m/s lobes by the singular points are curves, not specks
    b, w, v = P.refined_plane(ds, lambda b0, w30: steady.throw_speed(b0, w30, p))
    ax.contourf(b, w, np.nan_to_num(v, nan=1e6, posinf=1e6), levels=[-1.0, v_throw], colors=["0.78"])
    cs = ax.contour(b, w, v, levels=list(V_LEVELS), colors=V_COLOURS, linewidths=1.4)
    P.singular_lines(ax)
    P.beta_omega_axes(ax, ds, rf"Kinetic energy limit (59): contours of $v_{{throw}}$; "
                              rf"shaded: $v_{{throw}} \leq$ {v_throw:g} m/s")
    # one label per speed, beside its line (the line stays whole: it may border the shading), clear
    # of the edges, the other lines and the singular points; the legend names every line, even a tiny one
    P.place_contour_labels(ax, cs, fmt=lambda x: f"{x:g} m/s", fontsize=8, margin=0.06, beside=True,
                           avoid=[(-np.pi / 2, 0.0), (np.pi / 2, 0.0)], walls=P.singular_polylines(ax))
    drawn = [lv for lv, segs in zip(cs.levels, cs.allsegs) if any(len(s) for s in segs)]
    handles = [Line2D([], [], color=c, lw=1.4, label=f"{lv:g} m/s") for lv, c in zip(V_LEVELS, V_COLOURS)
               if lv in drawn]
    handles.append(Patch(fc="0.78", label=rf"$v_{{throw}} \leq$ {v_throw:g} m/s"))
    fig.legend(handles=handles, loc="outside right upper", fontsize=9, title=r"$v_{throw}$ (59)")
    return fig


_study("fig7", "Kinetic-energy limit of the steady motions: throw speed (59) (paper Fig. 7)",
       [Var("throw_speed", "m s-1", "throw speed with the kinetic energy of the steady motion (59)"),
        _flag("within", "steady motion needs no more energy than a throw at v_throw (59)",
              "too_energetic within_reach")],
       _fig7_compute, _fig7_plot, 1e-7, v_throw=10.0)


# ---------------------------------------------------------------- Fig. 8: realisable motions
def _fig8_compute(coords, p, s):
    return {"region": steady.realisable_region(*coords, p, s["v_throw"]),
            "omega20": steady.omega20(*coords, p)}


def _fig8_plot(ds):
    p = params_of(ds)
    v_throw = float(setting_of(ds, "v_throw"))
    fig, ax = P.new_figure()
    b, w, region = P.plane(ds, "region")
    _, _, w20 = P.plane(ds, "omega20")
    letters = dict(zip(steady.REGION_FLAG_VALUES, ds["region"].attrs["flag_meanings"].split()))
    P.beta_omega_axes(ax, ds, rf"Realisable steady motions: $\mu$={_mu_text(p.mu)}, $v_{{throw}}$={v_throw:g} m/s; "
                              r"$\pm$: sign of $\omega_{20}$, dotted: $\omega_{20}=0$")
    P.region_map(ax, b, w, region, w20, letters)
    return fig


def _mu_text(mu: float) -> str:
    """mu for a title: a number, or the infinity sign (rolling only)."""
    return r"$\infty$" if np.isinf(mu) else f"{mu:g}"


_study("fig8", "Physically realisable steady motions (paper Fig. 8)",
       [Var("region", "1", "region of the realisable steady motion (Fig. 8): stable (54), rolling (56), "
            "within the throw energy (59)", dtype="int8", flag_values=steady.REGION_FLAG_VALUES,
            flag_meanings=steady.REGION_FLAG_MEANINGS),
        OMEGA20],
       _fig8_compute, _fig8_plot, 2e-6, v_throw=10.0, mu=1.0)
