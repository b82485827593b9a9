"""The agreement check of solver.simulate with the scipy reference (same rules), shared by tests."""

import numpy as np

from rimroll.solver.analysis.scipy_reference import reference
from rimroll.solver.engine.outcomes import PERIODIC_ROLLING
from rimroll.solver.engine.simulate import simulate


def compare_with_scipy(x, p, t_max, method="dp5", rtol=1e-8, atol=1e-10, t_end_fraction=1.0):
    """Assert that ``simulate`` agrees with scipy DOP853 at rtol 1e-11; return (ours, ref, keep).

    States whose scipy outcome changes between rtol 1e-9 and 1e-11 are boundary states and are
    excluded (``keep`` is False there). Outcomes must agree on >= 99.5% of the others; where they
    agree, t_end within 1e-6 relative (scaled by the run length in s: the global error of long
    dissipative runs grows ~ linearly in time) on at least ``t_end_fraction`` of the states and
    within 1e-5 on all; half periods within 1e-6; every lane with status ok.
    """
    ours = simulate(x, p, t_max=t_max, method=method, rtol=rtol, atol=atol)
    ref = reference(x, p, t_max=t_max, rtol=1e-11, atol=1e-12)
    ref9 = reference(x, p, t_max=t_max, rtol=1e-9, atol=1e-10)
    keep = ref["outcome"] == ref9["outcome"]
    agree = ours["outcome"] == ref["outcome"]
    assert agree[keep].mean() >= 0.995, np.flatnonzero(~agree & keep)
    both = agree & keep & (ref["t_end"] > 0)
    rel = np.abs(ours["t_end"][both] - ref["t_end"][both]) / ref["t_end"][both]
    scale = np.maximum(1.0, ref["t_end"][both] / 1.0)
    assert (rel < 1e-6 * scale).mean() >= t_end_fraction, np.flatnonzero(both)[np.argsort(rel)[-3:]]
    assert np.all(rel < 1e-5 * scale)
    per = both & (ref["outcome"] == PERIODIC_ROLLING)
    if per.any():
        np.testing.assert_allclose(ours["half_period"][per], ref["half_period"][per], rtol=1e-6)
    assert np.all(ours["status"] == 0)
    return ours, ref, keep
