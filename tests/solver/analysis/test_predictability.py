"""solver.predictability: basin entropy, uncertainty exponent and make probabilities.

The references are closed forms (entropy of a box cut by a straight line, the Wilson interval
at k = 0, the Weierstrass graph's dimension 2 + ln a / ln b), the limits of the definitions
(sigma -> 0 is simulate; a spread much wider than 2 pi in the periodic angle beta is the
uniform average over beta) and brute force with more samples.
"""

from __future__ import annotations

import numpy as np
import pytest

from rimroll import solver
from rimroll.solver.analysis import predictability as P

ROLLING = solver.Params(mu=float("inf"))
QUICK = dict(t_max=20.0, rtol=1e-6, atol=1e-9)


def H(p):
    """Shannon entropy [nats] of fractions p (zeros allowed)."""
    p = np.asarray(p, dtype=float)
    p = p[p > 0]
    return float(-(p * np.log(p)).sum())


# ---------------------------------------------------------------- basin entropy
def test_single_outcome_has_zero_entropy_and_no_boundary_box():
    res = P.basin_entropy(np.full((30, 40), 3))
    assert res.S_b == 0.0 and res.n_boundary_boxes == 0 and np.isnan(res.S_bb)
    assert res.n_boxes == 6 * 8


@pytest.mark.parametrize("column", [1, 7, 12, 14])
@pytest.mark.parametrize("box", [4, 5])
def test_straight_boundary_matches_closed_form(column, box):
    n = 40
    codes = np.where(np.arange(n)[None, :] < column, -7, 12) * np.ones((n, 1), dtype=int)  # any integers
    res = P.basin_entropy(codes, box)
    p = (column % box) / box  # one column of boxes is cut; p of its points lie left of the line
    rows, cols = n // box, n // box
    assert res.n_boxes == rows * cols
    if p == 0:
        assert res.n_boundary_boxes == 0 and res.S_b == 0.0
        return
    assert res.n_boundary_boxes == rows
    assert res.S_bb == pytest.approx(H([p, 1 - p]), rel=1e-12)
    assert res.S_b == pytest.approx(H([p, 1 - p]) / cols, rel=1e-12)
    assert res.S_bb <= P.LN2  # a straight line never exceeds ln 2 (equal only at p = 1/2)


def test_straight_plane_in_three_dimensions():
    codes = np.zeros((10, 10, 10), dtype=np.int8)
    codes[:, :, 3:] = 4  # a code beyond the four of today's engine
    res = P.basin_entropy(codes, 5)
    assert res.n_boundary_boxes == 4 and res.S_bb == pytest.approx(H([0.6, 0.4]))


@pytest.mark.parametrize("k", [2, 3, 5])
def test_random_codes_give_ln_k(k):
    codes = np.random.default_rng(k).integers(0, k, size=(400, 400))
    res = P.basin_entropy(codes, box=20)
    # Miller-Madow: the plug-in entropy of n = 400 draws falls short of ln k by about (k - 1) / (2 n)
    assert res.n_boundary_boxes == res.n_boxes
    assert np.log(k) - 0.01 < res.S_bb < np.log(k)
    assert res.S_bb == pytest.approx(np.log(k) - (k - 1) / 800, abs=3e-3)


def test_box_entropy_map_shape_and_trailing_points_left_out():
    codes = np.zeros((12, 17), dtype=int)
    codes[:, 16] = 1  # in the trailing column that fills no whole box
    s = P.box_entropy(codes, 5)
    assert s.shape == (2, 3) and (s == 0).all()


@pytest.mark.parametrize("codes, box, match", [
    (np.zeros((4, 4)), 2, "integers"),
    (np.zeros((4, 4), int), 5, "larger than the grid"),
    (np.zeros((4, 4), int), 0, "integer >= 1"),
])
def test_basin_entropy_rejects_bad_input(codes, box, match):
    with pytest.raises(ValueError, match=match):
        P.basin_entropy(codes, box)


# ---------------------------------------------------------------- uncertainty exponent
def _disk(n=1024):
    x = np.linspace(-1, 1, n)
    return (x[:, None] ** 2 + x[None, :] ** 2 < 0.5).astype(int)


def test_smooth_boundary_of_a_disk_on_a_grid_has_alpha_one():
    steps = [1, 2, 4, 8, 16]
    fr = P.grid_uncertainty_fraction(_disk(), steps)
    ex = P.uncertainty_exponent(steps, fr.f, fr.n)
    assert abs(ex.alpha - 1) < 3 * ex.alpha_err + 0.01
    assert ex.D == pytest.approx(2 - ex.alpha)
    # +-eps along x or y: a boundary element with normal angle t is crossed from a band of
    # width 2 eps max(|cos t|, |sin t|), whose mean over t is 2 sqrt(2) / pi; the circle has
    # radius r, the square side 2 and the grid spacing h = 2 / (n - 1)
    r, h = np.sqrt(0.5), 2 / 1023
    expected = 2 * np.pi * r * 2 * np.array(steps) * h * (2 * np.sqrt(2) / np.pi) / 4
    assert np.allclose(fr.f, expected, rtol=0.03)


def test_smooth_boundary_of_a_disk_sampled_has_alpha_one():
    states = np.random.default_rng(0).uniform(-1, 1, size=(50_000, 2))
    eps = np.logspace(-4, -2, 5)
    fr = P.perturbation_fraction(lambda x: (x[..., 0] ** 2 + x[..., 1] ** 2 < 0.5).astype(int), states, eps, [1, 1])
    ex = P.uncertainty_exponent(eps, fr.f, fr.n)
    assert abs(ex.alpha - 1) < 3 * ex.alpha_err


def test_perturbation_fraction_stops_a_state_at_its_first_moved_copy_with_the_same_answer():
    """Only the copies of states not yet uncertain are classified; the answer is that of
    classifying every copy (brute force here)."""
    rng = np.random.default_rng(1)
    states = rng.uniform(-1, 1, size=(2000, 3))
    eps = np.array([0.01, 0.05, 0.2])
    scale = np.array([1.0, 0.5, 0.0])

    def label(x):
        return (np.sin(3 * x[..., 0]) + x[..., 1] ** 2 > 0.2).astype(int) + (x[..., 2] > 0)

    seen = []

    def counting(x):
        seen.append(np.asarray(x).reshape(-1, 3).shape[0])
        return label(x)

    fr = P.perturbation_fraction(counting, states, eps, scale)
    ref = label(states)
    brute = np.zeros((eps.size, states.shape[0]), dtype=bool)
    for i, ep in enumerate(eps):
        for k in (0, 1):
            for sgn in (1, -1):
                moved = states.copy()
                moved[:, k] += sgn * ep * scale[k]
                brute[i] |= label(moved) != ref
    assert np.array_equal(fr.uncertain, brute)
    assert np.allclose(fr.f, brute.mean(axis=1))
    assert 0 < brute.sum() and sum(seen[1:]) < eps.size * states.shape[0] * 4  # fewer copies than all


def test_fractal_boundary_below_a_weierstrass_graph():
    """Region below W(x) = sum a^k cos(b^k pi x): graph dimension D = 2 + ln a / ln b (Kaplan,
    Mallet-Paret, Yorke 1984), so alpha = 2 - D = -ln a / ln b for perturbations along x."""
    a, b, terms = 0.5, 4, 16
    def weierstrass(x):
        return sum(a ** k * np.cos(b ** k * np.pi * x) for k in range(terms))

    def classify(s):
        return (s[..., 1] > weierstrass(s[..., 0])).astype(int)
    rng = np.random.default_rng(1)
    states = np.column_stack([rng.uniform(0, 1, 200_000), rng.uniform(-2, 2, 200_000)])
    eps = np.logspace(-6, -2, 9)  # three log-periods of b = 4 and more
    fr = P.perturbation_fraction(classify, states, eps, [1, 1])
    ex = P.uncertainty_exponent(eps, fr.f, fr.n)
    alpha = -np.log(a) / np.log(b)
    assert abs(ex.alpha - alpha) < 3 * ex.alpha_err + 0.01
    assert abs(ex.D - (2 + np.log(a) / np.log(b))) < 3 * ex.alpha_err + 0.01
    assert ex.alpha < 0.6  # clearly not a smooth boundary


def test_exponent_fit_of_an_exact_power_law_and_degenerate_input():
    eps = np.logspace(-3, -1, 6)
    ex = P.uncertainty_exponent(eps, 0.3 * eps ** 0.7)
    assert ex.alpha == pytest.approx(0.7) and ex.alpha_err < 1e-10 and ex.log_f0 == pytest.approx(np.log(0.3))
    assert np.isnan(P.uncertainty_exponent(eps, np.zeros(6)).alpha)  # no boundary at all
    only_two = P.uncertainty_exponent(eps, [0, 0, 0, 0, 0.1, 0.2])
    assert only_two.alpha == pytest.approx(np.log(2) / np.log(eps[5] / eps[4])) and np.isnan(only_two.alpha_err)
    with pytest.raises(ValueError, match="eps"):
        P.uncertainty_exponent([0.0, 1.0], [0.1, 0.2])


def test_a_section_without_boundary_and_without_sample_simulates_nothing():
    states, scale = _section(35.0, 4, 5)
    codes = np.zeros((4, 5), dtype=np.int8)
    uncertain, weight = P.section_uncertainty(states, codes, ROLLING, [0.5, 1.0], scale, n_sample=0, **QUICK)
    assert not uncertain.any() and not weight.any()
    assert np.isnan(P.sampled_fraction(uncertain[0], weight)[0])


def test_grid_uncertain_at_edges_compares_the_inside_neighbour_only():
    codes = np.array([0, 0, 1, 1, 1])
    assert P.grid_uncertain(codes, 1).tolist() == [False, True, True, False, False]
    assert P.grid_uncertain(codes, 2).tolist() == [True, True, True, True, False]
    assert not P.grid_uncertain(codes, 5).any()


def test_sampled_fraction_strata_split_equal_weights():
    u = np.array([1, 1, 0, 0, 0, 0, 0, 0], dtype=bool)
    edge = np.array([1, 1, 1, 0, 0, 0, 0, 0], dtype=bool)
    f, err = P.sampled_fraction(u)
    f_s, err_s = P.sampled_fraction(u, None, edge)
    assert f == f_s == 0.25
    # one stratum: 8 * 0.25 * 0.75; two: the edge stratum 3 * (2/3) (1/3), the rest 0
    assert err == pytest.approx(np.sqrt(8 * 0.25 * 0.75) / 8) and err_s == pytest.approx(np.sqrt(3 * 2 / 9) / 8)
    with pytest.raises(ValueError, match="`strata`"):
        P.sampled_fraction(u, None, edge[:3])


def test_sampled_fraction_is_unbiased_over_strata():
    rng = np.random.default_rng(3)
    truth = rng.random(100_000) < np.where(np.arange(100_000) < 2000, 0.4, 0.002)
    weight = np.zeros(truth.size)
    weight[:2000] = 1.0  # every point of the first stratum
    rest = rng.choice(np.arange(2000, truth.size), 5000, replace=False)
    weight[rest] = 98_000 / 5000
    f, err = P.sampled_fraction(truth, weight)
    assert abs(f - truth.mean()) < 3 * err
    mean = truth.mean()
    assert P.sampled_fraction(truth) == pytest.approx((mean, np.sqrt(mean * (1 - mean) / truth.size)))


def test_refined_axis_keeps_the_grid_bit_for_bit_and_divides_each_step():
    v = np.linspace(0.8, 1.8, 7)
    f = P.refined_axis(v, 4)
    assert f.size == 25 and np.array_equal(f[::4], v)  # the grid's own values, not recomputed
    assert np.allclose(np.diff(f), (v[1] - v[0]) / 4)
    assert np.array_equal(P.refined_axis(v, 1), v)
    for values, k, match in ((v, 0, "`k` must be an integer"), (v, 2.0, "`k` must be an integer"),
                             ([0.0, np.nan, 1.0], 2, "finite"), ([0.0, 1j], 2, "real numbers")):
        with pytest.raises(ValueError, match=match):
            P.refined_axis(values, k)


def test_refined_uncertain_reads_sub_step_pairs_from_the_fine_grid():
    # a boundary at x = 0.3 (fine grid of 1/8 step): the grid points 0, 1, ... around it
    x = P.refined_axis(np.arange(6.0), 8)
    fine = (x > 2.3).astype(int)
    u = P.refined_uncertain(fine, 8, [0.125, 0.25, 0.5, 1, 2])
    # the grid point 2 is 0.3 steps from the boundary: uncertain at eps >= 1/2, point 3 at eps >= 1
    assert u[:, 2].tolist() == [False, False, True, True, True]
    assert u[:, 3].tolist() == [False, False, False, True, True]
    # whole steps: as the grid itself says
    assert np.array_equal(u[3], P.grid_uncertain(fine[::8], 1))
    with pytest.raises(ValueError, match="multiple of 1/k"):
        P.refined_uncertain(fine, 8, [0.1])
    for k, eps, match in ((0, [0.5], "`k` must be an integer"), (2.5, [0.5], "`k` must be an integer"),
                          (8, [], "one or more")):
        with pytest.raises(ValueError, match=match):
            P.refined_uncertain(fine, k, eps)
    with pytest.raises(ValueError, match="`fine_codes`"):
        P.refined_uncertain(fine.astype(float), 8, [0.5])
    with pytest.raises(ValueError, match=r"\(n - 1\) k \+ 1"):
        P.refined_uncertain(fine[:-1], 8, [0.5])


# ---------------------------------------------------------------- on the outcome sections
def _section(omega2, n_beta, n_omega1):
    beta, w1 = np.linspace(0.8, 1.8, n_beta), np.linspace(-20, 20, n_omega1)
    B, W = np.meshgrid(beta, w1, indexing="ij")
    states = np.stack([B, W, np.full_like(B, omega2), np.full_like(B, 10.0)], axis=-1)
    return states, np.array([beta[1] - beta[0], w1[1] - w1[0], 0.0, 0.0])


def test_grid_reuse_agrees_with_simulated_perturbations_at_one_step():
    states, scale = _section(35.0, 30, 45)
    codes = solver.simulate(states, ROLLING, **QUICK)["outcome"]
    fr = P.uncertainty_fraction(states[1:-1, 1:-1], ROLLING, 1.0, scale, reference=codes[1:-1, 1:-1], **QUICK)
    from_grid = P.grid_uncertain(codes, 1)[1:-1, 1:-1]
    assert from_grid.any()
    assert np.mean(fr.uncertain[0] == from_grid) > 0.995  # linspace vs x + h may differ by an ulp


def test_rolling_only_fig11_section_has_a_smooth_boundary():
    states, scale = _section(35.0, 96, 144)
    codes = solver.simulate(states, ROLLING, **QUICK)["outcome"]
    eps = np.array([0.25, 0.5, 1, 2, 4])
    uncertain, weight = P.section_uncertainty(states, codes, ROLLING, eps, scale, n_sample=500, **QUICK)
    f, err = np.array([P.sampled_fraction(u, weight if e < 1 else None) for u, e in zip(uncertain, eps)]).T
    ex = P.uncertainty_exponent(eps, f, f * (1 - f) / err ** 2)
    assert abs(ex.alpha - 1) < 0.1
    assert P.basin_entropy(codes).S_bb < P.LN2


@pytest.mark.slow
@pytest.mark.parametrize("omega2", [35.0, 65.0, 105.0])
def test_rolling_only_full_sections_are_smooth(omega2):
    states, scale = _section(omega2, 240, 360)
    codes = solver.simulate(states, ROLLING, method="dp5", **QUICK)["outcome"]  # section_uncertainty's own default
    eps = np.array([0.125, 0.25, 0.5, 1, 2, 4])
    uncertain, weight = P.section_uncertainty(states, codes, ROLLING, eps, scale, n_sample=2000, **QUICK)
    f, err = np.array([P.sampled_fraction(u, weight if e < 1 else None) for u, e in zip(uncertain, eps)]).T
    ex = P.uncertainty_exponent(eps, f, f * (1 - f) / err ** 2)
    assert abs(ex.alpha - 1) < 3 * ex.alpha_err + 0.02
    assert P.basin_entropy(codes).S_bb < P.LN2


# ---------------------------------------------------------------- make probability
def test_wilson_interval_closed_forms():
    z2 = 1.959963984540054 ** 2
    lo, hi = P.wilson_interval(0, 10, 0.95)
    assert lo == 0 and hi == pytest.approx(z2 / (10 + z2))
    lo, hi = P.wilson_interval(10, 10, 0.95)
    assert hi == pytest.approx(1) and lo == pytest.approx(10 / (10 + z2))
    n = np.arange(1, 400)  # no count gives a rounding residue for the exact 0 (1) of k = 0 (k = n)
    assert np.all(P.wilson_interval(0, n, 0.95)[0] == 0.0) and np.all(P.wilson_interval(n, n, 0.95)[1] == 1.0)
    lo, hi = P.wilson_interval(50, 100, 0.95)
    assert (lo + hi) / 2 == pytest.approx(0.5) and hi - lo == pytest.approx(2 * np.sqrt(z2) / (1 + z2 / 100) *
                                                                            np.sqrt(0.25 / 100 + z2 / 40000))


NOMINAL = np.array([[1.0, -5.0, 35.0, 10.0], [1.3, 2.0, 35.0, 10.0], [1.55, 12.0, 35.0, 10.0],
                    [0.9, 17.0, 35.0, 10.0]])


def test_zero_sigma_is_simulate():
    res = P.make_probability(NOMINAL, ROLLING, (0, 0, 0, 0), n_samples=3, **QUICK)
    direct = solver.simulate(NOMINAL, ROLLING, **QUICK)["outcome"]
    codes = res["codes"].tolist()
    assert set(solver.OUTCOME_MEANINGS) <= set(codes)
    expected = np.zeros((len(NOMINAL), len(codes)))
    expected[np.arange(len(NOMINAL)), [codes.index(c) for c in direct]] = 1.0
    assert np.array_equal(res["probability"], expected)
    tiny = P.make_probability(NOMINAL, ROLLING, (1e-13, 1e-12, 1e-12, 1e-12), n_samples=8, **QUICK)
    assert np.array_equal(tiny["probability"], expected)


def test_wide_spread_in_beta_gives_the_average_over_the_circle():
    """beta is an angle: a spread of 100 rad makes beta mod 2 pi uniform, so every nominal state
    gets the fractions of the outcomes over beta in [0, 2 pi) at its omegas."""
    n = 2000
    res = P.make_probability(NOMINAL[:2], ROLLING, (100.0, 0, 0, 0), n_samples=n, seed=5, **QUICK)
    codes = res["codes"]
    for i, state in enumerate(NOMINAL[:2]):
        circle = np.tile(state, (4000, 1))
        circle[:, 0] = np.linspace(0, 2 * np.pi, 4000, endpoint=False)
        out = solver.simulate(circle, ROLLING, **QUICK)["outcome"]
        fractions = np.array([(out == c).mean() for c in codes])
        err = np.sqrt(fractions * (1 - fractions) / n)
        assert np.all(np.abs(res["probability"][i] - fractions) <= 4 * err + 1e-9)


def test_interval_covers_an_estimate_with_ten_times_the_samples():
    sigma = (0.05, 1.5, 2.0, 1.0)
    small = P.make_probability(NOMINAL, ROLLING, sigma, n_samples=64, seed=1, confidence=0.99, **QUICK)
    big = P.make_probability(NOMINAL, ROLLING, sigma, n_samples=640, seed=2, **QUICK)
    assert np.array_equal(small["codes"], big["codes"])
    assert ((big["probability"] > 0.05) & (big["probability"] < 0.95)).any()  # some points are uncertain
    assert np.all((small["lower"] <= big["probability"]) & (big["probability"] <= small["upper"]))
    assert np.allclose(small["probability"].sum(axis=-1), 1.0)


def test_common_random_numbers_and_reproducibility():
    sigma = (0.05, 1.5, 2.0, 1.0)
    batch = P.make_probability(NOMINAL, ROLLING, sigma, n_samples=16, seed=7, block=20, **QUICK)
    alone = P.make_probability(NOMINAL[2:3], ROLLING, sigma, n_samples=16, seed=7, **QUICK)
    assert np.array_equal(batch["count"][2:3], alone["count"])  # same draws whatever the batch
    again = P.make_probability(NOMINAL, ROLLING, sigma, n_samples=16, seed=7, **QUICK)
    assert np.array_equal(batch["count"], again["count"])
    other = P.make_probability(NOMINAL, ROLLING, sigma, n_samples=16, seed=8, **QUICK)
    assert not np.array_equal(other["count"], again["count"])


@pytest.mark.parametrize("kwargs, match", [
    (dict(sigma=(0.1, -1, 0, 0)), "sigma"),
    (dict(sigma=(0.1, 1)), "sigma"),
    (dict(sigma=(0.1, 1, 1, 1), n_samples=0), "n_samples"),
    (dict(sigma=(0.1, 1, 1, 1), confidence=1.5), "confidence"),
])
def test_make_probability_rejects_bad_input(kwargs, match):
    with pytest.raises(ValueError, match=match):
        P.make_probability(NOMINAL, ROLLING, **{"n_samples": 2, **kwargs})


def test_uncertainty_fraction_rejects_bad_scale_and_eps():
    with pytest.raises(ValueError, match="scale"):
        P.uncertainty_fraction(NOMINAL, ROLLING, 0.1, (0, 0, 0, 0))
    with pytest.raises(ValueError, match="eps"):
        P.uncertainty_fraction(NOMINAL, ROLLING, -0.1, (0.1, 0, 0, 0))


# ---------------------------------------------------------------- the named studies
@pytest.fixture(scope="module")
def studies(tmp_path_factory):
    import xarray as xr

    from rimroll.study.cli import main

    out = tmp_path_factory.mktemp("predictability")
    assert main(["run", "predictability", "--quick", "--set", "omega2=65", "--set", "n_sample=50",
                 "--out", str(out), "--no-progress"]) == 0
    assert main(["run", "make-probability", "--quick", "--set", "n_beta=6", "--set", "n_omega1=8",
                 "--set", "n_samples=8", "--set", "sigma=0,1", "--out", str(out), "--no-progress"]) == 0
    return {name: xr.open_dataset(out / f"{name}.nc") for name in ("predictability", "make-probability")}


def test_predictability_study_file(studies):
    ds = studies["predictability"]
    assert ds["f"].dims == ("scene", "eps") and ds["alpha"].dims == ("scene",)
    assert ds["eps"].values.tolist() == [0.125, 0.25, 0.5, 1.0, 2.0]
    for name in ("S_b", "S_bb", "n_boundary_boxes", "f", "f_err", "alpha", "alpha_err", "D", "box_entropy"):
        assert ds[name].attrs["units"] and ds[name].attrs["long_name"]
    codes = ds["outcome"].transpose("scene", "beta", "omega1").values
    bits = ds["uncertain"].transpose("scene", "beta", "omega1").values
    for k in range(ds.sizes["scene"]):
        # whole eps: every point's flag, as the grid says
        for j, e in enumerate(ds["eps"].values):
            if e >= 1:
                assert np.array_equal((bits[k] >> j) & 1, P.grid_uncertain(codes[k], int(e)))
        assert (np.diff(ds["f"].isel(scene=k).values) > 0).all()  # f grows with eps
    assert np.allclose(ds["D"], 2 - ds["alpha"])
    # the bootstrap of alpha (solver.analysis.exponent_bootstrap): finite where alpha is, an interval
    for name in ("alpha_err_states", "alpha_err_bootstrap", "alpha_low", "alpha_high"):
        assert ds[name].attrs["units"] == "1" and ds[name].attrs["long_name"] and ds[name].dims == ("scene",)
        assert np.array_equal(np.isfinite(ds[name].values), np.isfinite(ds["alpha"].values))
    finite = np.isfinite(ds["alpha"].values)
    assert finite.any()
    assert (ds["alpha_low"].values[finite] < ds["alpha_high"].values[finite]).all()
    assert (ds["alpha_err_states"].values[finite] > 0).all()
    roll = ds.isel(scene=0)
    assert float(roll["S_bb"]) < np.log(2) and abs(float(roll["alpha"]) - 1) < 3 * float(roll["alpha_err"])


def test_eps_pairs_refined_reads_the_sampled_points_flags_from_the_refinement(tmp_path, capsys):
    """eps_pairs = refined (every grid point, its sub-step pairs from an adaptive map 2**n_fine times finer)
    gives the outcome grid of the sampled run and, at every point that run simulated, the same flags."""
    import xarray as xr

    from rimroll.study.cli import main

    files = {}
    for how in ("sampled", "refined"):
        assert main(["run", "predictability", "--quick", "--set", "omega2=65", "--set", f"eps_pairs={how}",
                     "--out", str(tmp_path / how), "--no-progress"]) == 0
        files[how] = xr.open_dataset(tmp_path / how / "predictability.nc")
    a, b = files["sampled"], files["refined"]
    assert b.attrs["setting_eps_pairs"] == "refined"
    assert np.array_equal(a["outcome"], b["outcome"])
    sampled = a["sample_weight"].values > 0
    assert sampled.sum() > 100
    assert np.array_equal(a["uncertain"].values[sampled], b["uncertain"].values[sampled])
    assert (b["sample_weight"] == 1).all()  # every point tested at every eps
    assert 0 < int(b["eps_runs"].sum()) < 0.5 * b["outcome"].size * 64  # the fine grid, not all of it
    assert np.isfinite(b["alpha"]).all() and (b["alpha_low"] < b["alpha_high"]).all()
    assert "refined" in b["alpha_err_states"].attrs["comment"] and "two-phase" in a["alpha_err_states"].attrs["comment"]
    # the refined file is not verified against the sampled reference (another estimator below one step)
    from rimroll.study.compare import compare

    sampled_reference = a.copy()
    del sampled_reference.attrs["setting_eps_pairs"]  # as the stored slices, made before the setting
    for reference in (a, sampled_reference):
        report = compare(b, reference)
        assert report.n_common == 0 and "eps_pairs: refined (file) vs sampled" in report.reason
    # study verify names the slice whose settings differ least: the quick one, eps_pairs alone
    assert main(["verify", str(tmp_path / "refined" / "predictability.nc")]) == 1
    out = capsys.readouterr().out
    assert "quick" in out and "eps_pairs: refined" in out and "box" not in out, out


def test_eps_pairs_refined_equals_a_sample_of_every_point(tmp_path):
    """Sampling every point (n_sample above the points certain at one step) and reading the refined map
    give the same f and f_err: the same two strata, every point of each tested."""
    import xarray as xr

    from rimroll.study.cli import main

    common = ["--quick", "--set", "omega2=35", "--set", "n_beta=12", "--set", "n_omega1=18", "--no-progress"]
    for how, extra in (("sampled", ["--set", "n_sample=100000"]), ("refined", [])):
        assert main(["run", "predictability", *common, *extra, "--set", f"eps_pairs={how}",
                     "--out", str(tmp_path / how)]) == 0
    a, b = (xr.open_dataset(tmp_path / how / "predictability.nc") for how in ("sampled", "refined"))
    assert np.array_equal(a["uncertain"], b["uncertain"])
    np.testing.assert_allclose(a["f"], b["f"], rtol=1e-12)
    np.testing.assert_allclose(a["f_err"], b["f_err"], rtol=1e-12)


def test_the_cost_model_knows_the_refined_eps_test_costs_more():
    from rimroll.study import registry, run_notices
    from rimroll.study.plan import make_plan

    study = registry.get("predictability")
    sampled = run_notices.core_seconds(make_plan(study, True))
    refined = run_notices.core_seconds(make_plan(study, True, {"eps_pairs": "refined"}))
    assert refined == pytest.approx(5 * sampled)


def test_eps_pairs_refined_refuses_a_refined_grid_too_large_in_one_line(tmp_path, capsys):
    from rimroll.study.cli import main

    assert main(["run", "predictability", "--quick", "--set", "eps_pairs=refined", "--set", "n_fine=12",
                 "--out", str(tmp_path), "--no-progress"]) != 0
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "eps_pairs=refined" in err[0] and "lower n_fine" in err[0]
    for item, needle in (("eps_pairs=refined,sampled", "takes one of sampled, refined, not a list"),
                         ("n_coarse=5", "must be shorter than the grid")):
        assert main(["run", "predictability", "--quick", "--set", item, "--out", str(tmp_path), "--no-progress"]) == 2
        err = capsys.readouterr().err.strip().splitlines()
        assert len(err) == 1 and needle in err[0], err


def test_make_probability_study_file(studies):
    ds = studies["make-probability"]
    names = [m.split(":")[0] for m in solver.OUTCOME_MEANINGS.values()]
    total = sum(ds[f"p_{n}"] for n in names)
    assert np.allclose(total, 1.0)
    for n in names:
        assert (ds[f"p_{n}_lower"] <= ds[f"p_{n}"]).all() and (ds[f"p_{n}"] <= ds[f"p_{n}_upper"]).all()
    still = ds.sel(sigma=0.0)  # no noise: the deterministic outcome with probability 1
    for code, n in zip(solver.OUTCOME_MEANINGS, names):
        assert np.array_equal(still[f"p_{n}"].values == 1.0, still["outcome"].values == code)
    assert ds["sigma"].attrs["units"] == "1"


def test_negative_noise_level_is_a_user_error(tmp_path, capsys):
    from rimroll.study.cli import main

    assert main(["run", "make-probability", "--quick", "--set", "sigma=-1,1", "--out", str(tmp_path)]) == 2
    assert "sigma" in capsys.readouterr().err


def test_derive_may_add_a_dimension_with_its_coordinate_or_one_size_for_all_its_variables():
    import xarray as xr

    from rimroll.study.derived_variables import derived_variables
    from rimroll.study.registry import Study, Var

    ds = xr.Dataset({"x": (("a",), np.arange(3.0))})
    attrs = {"units": "1", "long_name": "test"}

    def make(coordinate=None, other=None):
        out = {"g": (("a", "e"), np.zeros((3, 2)), attrs)}
        if coordinate is not None:
            out["e"] = (("e",), np.zeros(coordinate), attrs)
        if other is not None:  # a second variable along e (a ragged array's)
            out["h"] = (("e",), np.zeros(other), attrs)
        return Study(name="probe", title="t", settings={}, axes=lambda s: [], variables=[Var("x", "1", "x")],
                     compute=lambda *a: {}, derive=lambda d: out)

    extra = derived_variables(make(coordinate=2), ds)
    assert list(extra)[0] == "e" and extra["g"][1].shape == (3, 2)  # the coordinate comes first
    assert set(derived_variables(make(other=2), ds)) == {"g", "h"}  # no coordinate: sizes agree
    for bad in (dict(coordinate=3), dict(other=5)):
        with pytest.raises(ValueError, match="new dimension"):
            derived_variables(make(**bad), ds)


def test_settings_checks_accept_predictabilitys_zero_counts_and_refuse_its_ignored_parameters(tmp_path, capsys):
    """Merged with the run checks of study.checks: n_fine, n_coarse, n_sample may be 0 (the study's
    own rule) while a grid size may not; mu, k_r, k_d are set by the scenes, so --set refuses them."""
    from rimroll.study.checks import check_setting
    from rimroll.study.cli import main
    from rimroll.study.registry import UserError

    for key in ("n_fine", "n_coarse", "n_sample"):
        check_setting("predictability", key, 0)
    with pytest.raises(UserError, match="n_beta"):
        check_setting("predictability", "n_beta", 0)
    assert main(["run", "predictability", "--quick", "--set", "k_d=0.1", "--out", str(tmp_path)]) == 2
    assert "k_d" in capsys.readouterr().err
