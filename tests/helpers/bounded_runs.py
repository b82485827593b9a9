"""Runs of the outcome engine with bounded work, for its hard numerical cases, and what every such case checks.

Each case bounds the work (t_max, max_steps) and asserts the behaviour that is correct, not merely what
the engine does today (two of them first failed and led to engine fixes: the transversality of omega1
zeros, and grazing falls hidden between dense-output samples).
"""

from __future__ import annotations

import numpy as np

from rimroll import solver
from rimroll.solver.engine import outcomes

P = solver.Params()  # Table 1, mu = 1
ROLL = P.replace(mu=float("inf"))
WEIGHT = P.m * P.g  # [N]
FLOAT_FIELDS = ("t_end", "f2_min", "revolutions", "slip_time", "energy_drift",
                "beta_end", "omega1_end", "omega2_end", "omega3_end")


def sim(states, p, **kw):
    """``solver.simulate`` of ``states`` (one state or rows) on one worker unless told otherwise."""
    kw.setdefault("workers", 1)
    return solver.simulate(np.atleast_2d(np.asarray(states, float)), p, **kw)


def assert_finite(r):
    """Every float output of ``r`` is finite; the half period is finite exactly where rolling is periodic."""
    for name in FLOAT_FIELDS:
        assert np.all(np.isfinite(r[name])), (name, r[name])
    periodic = r["outcome"] == outcomes.PERIODIC_ROLLING
    assert np.all(np.isfinite(r["half_period"][periodic]))
    assert np.all(np.isnan(r["half_period"][~periodic]))


def mechanical_energy(beta, w1, w2, w3, p=P):
    """Mechanical energy (60) with the potential m g rho sin(beta) [J]."""
    r2 = p.r**2
    return (0.5 * p.m * p.j * r2 * w2**2 + 0.5 * p.m * (1 + p.j) * r2 * (w1**2 + w3**2)
            + p.m * p.g * p.rho * np.sin(beta))
