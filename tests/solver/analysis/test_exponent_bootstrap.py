"""Bootstrap error bars of the uncertainty exponent (solver.analysis.exponent_bootstrap): the
resampled f(eps) reduce to the nominal ones, the error is calibrated against independent samples,
and its interval tells a smooth boundary (alpha = 1) from a fractal one."""

from __future__ import annotations

import numpy as np
import pytest

from rimroll.solver.analysis import exponent_bootstrap as B
from rimroll.solver.analysis import predictability as P


def _two_phase_disk(n_sample=1500, seed=1, n=120, m=180):
    """A disk on an n x m grid, eps = 1/8 ... 4 grid steps, the eps < 1 flags exact (the disk is
    analytic) but known only on the edge and a random sample of the rest, as section_uncertainty
    leaves them. Returns eps, uncertain (n_eps, N), sampled, rest, weight."""
    i, j = np.mgrid[:n, :m]
    eps = 2.0 ** np.arange(-3, 3)

    def inside(x, y):
        return (x - n / 2 - 0.3) ** 2 + (y - m / 2 - 0.7) ** 2 < (n / 3.5) ** 2
    c = inside(i, j)
    u = np.stack([(c ^ inside(i + e, j)) | (c ^ inside(i - e, j)) | (c ^ inside(i, j + e)) | (c ^ inside(i, j - e))
                  for e in eps]).reshape(eps.size, -1)
    rest = ~u[3]
    take = np.random.default_rng(seed).choice(np.flatnonzero(rest), n_sample, replace=False)
    sampled = ~rest
    sampled[take] = True
    weight = np.where(~rest, 1.0, 0.0)
    weight[take] = rest.sum() / n_sample
    return eps, u, sampled, rest, weight


def test_unit_counts_give_the_nominal_stratified_fractions():
    eps, u, sampled, rest, weight = _two_phase_disk()
    f = B.fractions(eps, u, sampled, rest, np.ones((1, u.shape[1])))[0]
    nominal = [P.sampled_fraction(u[k], weight if e < 1 else None)[0] for k, e in enumerate(eps)]
    assert f == pytest.approx(nominal, rel=1e-6)
    # doubling every count changes nothing; drawing only the edge points gives f = 1 at eps = 1
    assert B.fractions(eps, u, sampled, rest, 2 * np.ones((1, u.shape[1])))[0] == pytest.approx(f, rel=1e-6)
    assert B.fractions(eps, u, sampled, rest, (~rest)[None].astype(float))[0][3] == pytest.approx(1.0)


EPS = np.logspace(-3, -1.5, 5)


def _sampled_disk(seed, n_states=20_000, eps=EPS):
    """f(eps) of independent uniform states around a disk (every flag known)."""
    states = np.random.default_rng(seed).uniform(-1, 1, size=(n_states, 2))
    fr = P.perturbation_fraction(lambda x: (x[..., 0] ** 2 + x[..., 1] ** 2 < 0.5).astype(int), states, eps, [1, 1])
    return eps, fr


def test_bootstrap_error_over_states_matches_the_spread_of_independent_samples():
    alphas, errs = [], []
    for seed in range(16):
        eps, fr = _sampled_disk(seed)
        alphas.append(P.uncertainty_exponent(eps, fr.f, fr.n).alpha)
        everyone = np.ones(fr.uncertain.shape[1], dtype=bool)
        b = B.bootstrap_exponent(eps, fr.uncertain, everyone, ~fr.uncertain[-1], fr.n, n_boot=200, seed=seed)
        errs.append(b.err_states)
    ratio = np.mean(errs) / np.std(alphas, ddof=1)
    assert 0.6 < ratio < 1.6, ratio  # 16 samples: the std itself is known to about 18 %


def test_the_interval_holds_one_for_a_smooth_boundary_and_not_for_a_fractal_one():
    eps, u, sampled, rest, weight = _two_phase_disk()
    f = np.array([P.sampled_fraction(u[k], weight if e < 1 else None) for k, e in enumerate(eps)])
    n_eff = f[:, 0] * (1 - f[:, 0]) / f[:, 1] ** 2
    smooth = B.bootstrap_exponent(eps, u, sampled, rest, n_eff, n_boot=300, seed=0)
    assert smooth.low < 1 < smooth.high
    assert smooth.err >= smooth.err_states > 0  # the eps windows add to the states' spread here
    assert smooth.replicates.shape == (300, 2)

    a, b, terms = 0.5, 4, 16  # the region below a Weierstrass graph: alpha = -ln a / ln b = 0.5

    def classify(s):
        return (s[..., 1] > sum(a ** k * np.cos(b ** k * np.pi * s[..., 0]) for k in range(terms))).astype(int)
    rng = np.random.default_rng(1)
    states = np.column_stack([rng.uniform(0, 1, 40_000), rng.uniform(-2, 2, 40_000)])
    eps = np.logspace(-5, -2, 7)
    fr = P.perturbation_fraction(classify, states, eps, [1, 1])
    rough = B.bootstrap_exponent(eps, fr.uncertain, np.ones(states.shape[0], bool), ~fr.uncertain[-1], fr.n,
                                 n_boot=300, seed=0)
    assert rough.high < 1 and rough.low < 0.5 < rough.high


def test_windows_are_every_contiguous_run_of_at_least_min_points():
    w = B.windows(6, 3)
    assert len(w) == 10 and (0, 6) in w and all(b - a >= 3 for a, b in w)
    assert B.windows(3, 3) == [(0, 3)]


def test_bad_input_is_refused_with_one_line():
    eps, u, sampled, rest, _ = _two_phase_disk(n_sample=100, n=30, m=40)
    with pytest.raises(ValueError, match="`uncertain` must have shape"):
        B.bootstrap_exponent(eps[:-1], u, sampled, rest)
    with pytest.raises(ValueError, match="must be sampled"):
        B.bootstrap_exponent(eps, u, np.zeros_like(sampled), rest)
    with pytest.raises(ValueError, match="n_boot"):
        B.bootstrap_exponent(eps, u, sampled, rest, n_boot=1)
    with pytest.raises(ValueError, match="min_points"):
        B.bootstrap_exponent(eps, u, sampled, rest, min_points=9)
    with pytest.raises(ValueError, match="`counts` must have shape"):
        B.fractions(eps, u, sampled, rest, np.ones((1, 5)))
