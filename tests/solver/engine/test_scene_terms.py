"""The change exercise of docs/architecture.md: a term added through the scene table and one physics
function runs through ``simulate`` (CPU and the CUDA simulator) and the scipy reference.

The toy term damps omega2 at the rate TOY_RATE: the moment -j m r^2 TOY_RATE omega2 about n2. The
drilling resistance of (83) at k_d = TOY_RATE is the same physics written into the equations, so the
two runs must agree (to the integration tolerance: they round differently); a load of zero strength
gives the scene without it bit for bit.
"""

from __future__ import annotations

import numpy as np
import pytest

from rimroll import solver
from rimroll.solver._jit import physics_kernel
from rimroll.solver.analysis.scipy_reference import reference
from rimroll.solver.engine import outcomes, scene_code, scenes
from rimroll.solver.physics.params import P_J, P_M, P_R_BALL

TOY_RATE = 0.05  # [1/s]


@physics_kernel
def toy_drilling_damping(beta, omega1, omega2, omega3, u1, u3, p):
    """A linear damping of omega2 at TOY_RATE [1/s]: the moment (0, -j m r^2 TOY_RATE omega2, 0) [N m]."""
    return 0.0, -p[P_J] * p[P_M] * p[P_R_BALL] ** 2 * TOY_RATE * omega2, 0.0, 0.0, 0.0, 0.0


@physics_kernel
def toy_nothing(beta, omega1, omega2, omega3, u1, u3, p):
    """A load of zero strength."""
    return 0.0, 0.0, 0.0, 0.0, 0.0, 0.0


scenes.register_term(scenes.Term("toy_drilling", "toy damping of omega2", load=toy_drilling_damping))
scenes.register_term(scenes.Term("toy_nothing", "a load of zero strength", load=toy_nothing, dissipative=False))


def _states(n=120, seed=3):
    rng = np.random.default_rng(seed)
    return np.stack([rng.uniform(0.9, 1.6, n), rng.uniform(-6, 6, n), rng.choice([35.0, 65.0], n),
                     np.full(n, 10.0)], -1)


@pytest.mark.parametrize("mu", [np.inf, pytest.param(1.0, marks=pytest.mark.slow)])  # mu = 1: a second compile, ~40 s
def test_a_toy_term_equals_the_same_physics_written_into_the_equations(mu):
    x = _states()
    toy = solver.simulate(x, solver.Params(mu=mu), t_max=5.0, rtol=1e-10, atol=1e-12, terms=("toy_drilling",))
    builtin = solver.simulate(x, solver.Params(mu=mu, k_d=TOY_RATE), t_max=5.0, rtol=1e-10, atol=1e-12)
    same = toy["outcome"] == builtin["outcome"]
    assert same.mean() >= 0.97, np.flatnonzero(~same)
    assert np.allclose(toy["t_end"][same], builtin["t_end"][same], rtol=1e-6, atol=1e-6)
    assert (toy["outcome"] != outcomes.PERIODIC_ROLLING).all()  # a dissipative term: no periodic detection
    if np.isfinite(mu):
        assert toy["slip_phases"].max() > 0  # the load enters the slipping phase and the switches too


@pytest.mark.slow  # two generated-scene compiles, ~60 s (docs/contributing.md: the test suite's time)
def test_a_load_of_zero_strength_gives_the_scene_without_it_bit_for_bit():
    x = _states(60)
    for mu in (np.inf, 1.0):
        with_load = solver.simulate(x, solver.Params(mu=mu), t_max=5.0, terms=("toy_nothing",), method="dp5")
        without = solver.simulate(x, solver.Params(mu=mu), t_max=5.0, method="dp5")  # the kernel, not the exact solver
        for name in ("outcome", "t_end", "n_steps", "slip_phases", "beta_end", "omega2_end"):
            np.testing.assert_array_equal(with_load[name], without[name], err_msg=name)


@pytest.mark.parametrize("mu", [np.inf, pytest.param(1.0, marks=pytest.mark.slow)])  # mu = 1: a hybrid compile, 100 s
def test_the_scipy_reference_runs_the_same_term(mu):
    x = _states(8, seed=5)
    p = solver.Params(mu=mu)
    ours = solver.simulate(x, p, t_max=3.0, rtol=1e-10, atol=1e-12, terms=("toy_drilling",))
    ref = reference(x, p, t_max=3.0, rtol=1e-10, atol=1e-12, terms=("toy_drilling",))
    assert (ours["outcome"] == ref["outcome"]).all()
    np.testing.assert_allclose(ours["t_end"], ref["t_end"], rtol=1e-6, atol=1e-6)


def test_a_scene_with_load_terms_gets_a_generated_kernel_that_names_exactly_its_terms():
    scene = scenes.scene_of(solver.Params(mu=1.0), ("toy_drilling",))
    assert scene.name == "slipping+toy_drilling" and not scene.conservative
    text = scene_code.source(scene)
    assert "toy_drilling_damping as term_0" in text and "toy_nothing" not in text
    assert scene_code.kernel_of(scenes.scene_of(solver.Params(mu=1.0))).py_func.__name__ == "scene_hybrid"
    with pytest.raises(ValueError, match="unknown terms"):
        solver.simulate(_states(2), solver.Params(), terms=("no_such_term",))


def test_a_term_needs_a_load_defined_at_the_top_of_a_module():
    def local(beta, omega1, omega2, omega3, u1, u3, p):
        return 0.0, 0.0, 0.0, 0.0, 0.0, 0.0

    scenes.register_term(scenes.Term("toy_local", "a local function", load=local))
    try:
        with pytest.raises(ValueError, match="top level"):
            solver.simulate(_states(2), solver.Params(), terms=("toy_local",))
    finally:
        scenes.TERMS.pop("toy_local")


def test_a_damaged_generated_module_in_the_cache_is_rewritten(tmp_path, monkeypatch, caplog):
    """A generated scene module that is not valid text any more (a damaged cache) is written again,
    with one warning, not a UnicodeDecodeError."""
    from rimroll.solver import _jit

    monkeypatch.setattr(_jit, "cache_dir", lambda: tmp_path)
    monkeypatch.setattr(scene_code, "_MODULES", {})
    scene = scenes.scene_of(solver.Params(mu=1.0), ("toy_drilling",))
    path = tmp_path / "scenes" / f"{scene_code.module_name(scene)}.py"
    path.parent.mkdir(parents=True)
    path.write_bytes(b"\xff\xfe\x00damaged")
    assert scene_code.module(scene).load is not None
    assert path.read_text(encoding="utf-8") == scene_code.source(scene)
    assert [r.levelname for r in caplog.records if "could not be read" in r.getMessage()] == ["WARNING"]
