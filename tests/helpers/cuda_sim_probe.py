"""Run states of the four outcome scenes on the CPU engine and on the CUDA backend; save both.

Run in a process of its own with ``NUMBA_ENABLE_CUDASIM=1`` (numba-cuda's simulator is chosen
when ``numba.cuda`` is first imported): ``python tests/helpers/cuda_sim_probe.py OUT.npz N_PER_SCENE
[MAX_BATCH [SCENE,SCENE,...]]`` (MAX_BATCH 0: no batched run; default: every scene of ``SCENES``).
``tests/solver/engine/test_cuda_backend.py`` compares the two.

What costs is not the states but the compiles: under the simulator each (scene, method) compiles the
engine's trajectory kernel once more for the CPU (its call from Python), once into the kernel cache;
the coulomb_air scene (a generated scene module) compiles it again in every run, about 5 min at load 12
(tests/solver/engine/test_cuda_backend.py runs it with -m slow).
"""

from __future__ import annotations

import sys

import numpy as np

from rimroll import solver
from rimroll.solver.engine import cuda_backend
from rimroll.solver.engine.outputs import OUTPUTS

SCENES = {  # label: (Params changes, t_max [s]) as the outcome sections (workflows/outcome_grids.py)
    "rolling_only": ({"mu": np.inf}, 20.0),
    "slipping": ({"mu": 1.0}, 20.0),
    "drilling": ({"mu": 1.0, "k_d": 0.02}, 60.0),
    "rolling_resistance": ({"mu": 1.0, "k_r": 0.02}, 60.0),
    # the load terms of Sect. 5.3's question (a generated scene kernel): Coulomb resistances and air drag
    "coulomb_air": ({"mu": 1.0, "c_r": 1e-3, "c_d": 1e-3, "rho_air": 1.2}, 60.0),
}


OMEGA2, OMEGA3 = 35.0, 10.0  # [1/s] the Fig. 11 section


def section_states(n: int, seed: int = 14) -> np.ndarray:
    """n states of the Fig. 11 section (omega2 = 35, omega3 = 10 1/s): the steady motion (48) of
    the section, half the rest near it (beta0 +- 0.06 rad, omega1 +- 3 1/s: periodic orbits and
    long runs), half anywhere (beta in [0.8, 1.8], omega1 in [-20, 20]: falls)."""
    from scipy.optimize import brentq

    beta0 = brentq(lambda b: solver.steady.omega20(b, OMEGA3, solver.Params()) - OMEGA2, 0.8, 1.5)
    rng = np.random.default_rng(seed)
    near = (n - 1) // 2
    far = n - 1 - near
    beta = np.concatenate([[beta0], beta0 + rng.uniform(-0.06, 0.06, near), rng.uniform(0.8, 1.8, far)])
    omega1 = np.concatenate([[0.0], rng.uniform(-3.0, 3.0, near), rng.uniform(-20.0, 20.0, far)])
    return np.stack([beta, omega1, np.full(n, OMEGA2), np.full(n, OMEGA3)], -1)


def main(out: str, n: int, max_batch: int | None, labels: list[str] | None = None) -> None:
    states = section_states(n)
    saved = {"states": states}
    for label, (changes, t_max) in SCENES.items():
        if labels is not None and label not in labels:
            continue
        params = solver.Params(**changes)
        for backend in ("cpu", "cuda"):
            res = solver.simulate(states, params, t_max=t_max, method="dp5", backend=backend, workers=1)
            for name in (o.name for o in OUTPUTS):
                saved[f"{label}/{backend}/{name}"] = res[name]
    if max_batch:  # the batched path: several launches, both slots, against one launch
        params = solver.Params(mu=np.inf)
        flat = np.ascontiguousarray(states)
        res_f = np.full((n, solver.engine.kernels.N_RF), np.nan)
        res_i = np.full((n, solver.engine.kernels.N_RI), -1, dtype=np.int64)
        from rimroll.solver.engine.kernels import Limits
        from rimroll.solver.engine.scenes import scene_of
        from rimroll.solver.physics.switching import default_tolerances

        cuda_backend.run(scene_of(params), "dp5", flat, params.as_array(),
                         Limits(20.0, 1e-8, 1e-10, 1_000_000, 10_000, True), default_tolerances(), res_f, res_i,
                         max_batch=max_batch)
        saved["batched/res_f"] = res_f
        saved["batched/res_i"] = res_i
    saved["device"] = np.array(solver.engine.backends.resolve("cuda").describe())
    np.savez(out, **saved)


if __name__ == "__main__":
    main(sys.argv[1], int(sys.argv[2]), int(sys.argv[3]) if len(sys.argv) > 3 else None,
         sys.argv[4].split(",") if len(sys.argv) > 4 else None)
