"""Real air on the periodic islands of Figs. 11-13: alone, and with the Coulomb pair at the paper's strength.

The study ``dissipation-models`` puts every model on one strength scale (k_equivalent); real air
(rho_air = 1.2 kg/m^3, C_D = 0.5) sits at k_eq = 7e-4 1/s, below its grid. This script runs the
islands of a ``dissipation-models`` file (the README's numbers: the full run) with real air alone,
the Coulomb rolling + drilling pair at k_eq = 0.02 1/s, and both, with slipping (mu = 1) to 60 s,
and prints the percent that falls in / out / is still on the rim.

    python benchmarks/dissipation_real_air.py results/dissipation-models.nc      # about 30 s on 2 cores
"""

import sys

import numpy as np
import xarray as xr

from rimroll import solver
from rimroll.workflows import dissipation


def main(path: str) -> None:
    ds = xr.open_dataset(path)
    f = dissipation.equivalence(solver.Params())
    print(f"real air (rho_air = 1.2 kg/m^3): k_eq = {1.2 / f['rho_air']:.2g} 1/s")
    pair = dict(c_r=0.02 * f["c_r"], c_d=0.02 * f["c_d"])
    cases = {"real air": dict(rho_air=1.2), "Coulomb pair, 0.02": pair, "Coulomb pair, 0.02, + real air":
             dict(pair, rho_air=1.2)}
    print("| island | " + " | ".join(cases) + " |\n|---|" + "---|" * len(cases))
    first = ds.isel(k_equivalent=0, model=0)
    for w2 in first["omega2"].values:
        for island in first["island"].values:
            one = first.sel(omega2=w2, island=island)
            inside = one["fate"].values != dissipation.OUTSIDE
            b, w = np.meshgrid(one["beta"].values, one["omega1"].values, indexing="ij")
            x = np.stack([b[inside], w[inside], np.full(inside.sum(), w2), np.full(inside.sum(), 10.0)], -1)
            row = []
            for kw in cases.values():
                res = solver.simulate(x, solver.Params(mu=1.0, **kw), t_max=60.0, terms=dissipation.LOAD_TERMS)
                counts = np.bincount(res["outcome"], minlength=4)[[0, 1, 3]]
                row.append(" / ".join(f"{100 * c / len(x):.0f}" for c in counts))
            print(f"| omega2 = {w2:g}, {island} ({len(x)}) | " + " | ".join(row) + " |", flush=True)


if __name__ == "__main__":
    main(sys.argv[1] if len(sys.argv) > 1 else "results/dissipation-models.nc")
