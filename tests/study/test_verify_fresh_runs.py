"""``study verify`` of every study's fresh ``--quick`` run passes, here and on another machine.

A reference slice is a regression test a user runs on their own machine, so each variable's tolerance
must cover what round-off can move it by (its conditioning: a fitted rate, a state found from a
cancelling difference), not only what this machine computes. The runs are repeated with round-off
perturbed as another machine perturbs it: numpy's transcendental functions without its widest SIMD
kernels (they differ from the narrower ones in the last bits, as they do between CPUs), one BLAS
thread and one worker. Every study of rimroll, every perturbation: the cases are generated from the
registry, so a new study is covered without a new line here.
"""

from __future__ import annotations

import os
import subprocess
import sys

import numpy as np
import pytest

from rimroll.study import reference, registry


def _widest_simd() -> str | None:
    """The widest SIMD feature group numpy found on this CPU (what NPY_DISABLE_CPU_FEATURES can turn
    off), or None where it found none it can turn off."""
    try:
        from numpy._core._multiarray_umath import __cpu_features__ as found
    except ImportError:  # numpy < 2
        from numpy.core._multiarray_umath import __cpu_features__ as found
    for name in ("X86_V4", "AVX512F", "X86_V3", "AVX2", "ASIMDHP", "SVE"):
        if found.get(name):
            return name
    return None


def _perturbations() -> list:
    """(id, environment, extra arguments) of each way of running a study."""
    out = [pytest.param({}, [], id="as-built")]
    widest = _widest_simd()
    other = {"OPENBLAS_NUM_THREADS": "1", "OMP_NUM_THREADS": "1", "MKL_NUM_THREADS": "1"}
    if widest:
        other["NPY_DISABLE_CPU_FEATURES"] = widest
    out.append(pytest.param(other, ["--workers", "1"], id="another-machine"))
    return out


def _study(tmp_path, env: dict, *args) -> subprocess.CompletedProcess:
    full = {**os.environ, **env}
    return subprocess.run([sys.executable, "-m", "rimroll.study", *args], capture_output=True, text=True,
                          env=full, cwd=tmp_path, timeout=900)


@pytest.mark.slow
@pytest.mark.parametrize("env,extra", _perturbations())
@pytest.mark.parametrize("name", list(reference.specs()))
def test_a_fresh_quick_run_verifies(name, env, extra, tmp_path):
    run = _study(tmp_path, env, "run", name, "--quick", "--out", str(tmp_path), "--no-progress", *extra)
    assert run.returncode == 0, run.stderr
    verify = _study(tmp_path, env, "verify", str(tmp_path / f"{name}.nc"))
    assert verify.returncode == 0, verify.stdout + verify.stderr
    assert "result: within tolerance" in verify.stdout


def test_the_perturbation_changes_round_off():
    """The 'another-machine' run is another computation at round-off, not the same bits: numpy's sin
    and exp without the widest SIMD kernels differ in the last bits at some of a million points."""
    widest = _widest_simd()
    if widest is None:
        pytest.skip("numpy found no SIMD feature group it can turn off on this CPU")
    code = ("import numpy as np, sys; x = np.linspace(-10, 10, 10**6); "
            "sys.stdout.buffer.write((np.sin(x) + np.exp(x / 10)).tobytes())")
    runs = [subprocess.run([sys.executable, "-c", code], capture_output=True, env={**os.environ, **env},
                           timeout=60, check=True).stdout
            for env in ({}, {"NPY_DISABLE_CPU_FEATURES": widest})]
    a, b = (np.frombuffer(r) for r in runs)
    assert a.shape == b.shape == (10**6,)
    differ = a != b
    assert differ.any(), f"NPY_DISABLE_CPU_FEATURES={widest} changed no result: the perturbation is vacuous"
    assert np.max(np.abs(a - b)) < 8 * np.finfo(float).eps  # round-off of values <= 4, not another function


def test_declared_tolerances_name_existing_variables():
    """A tolerance set next to a study's variables names one of them and is (atol, rtol) >= 0."""
    for name in registry.names():
        for v in registry.get(name).variables:
            if v.tolerance is not None:
                atol, rtol = v.tolerance
                assert 0 <= atol < np.inf and 0 <= rtol < np.inf, (name, v.name)
    variables = registry.get("solution-types").variables
    with pytest.raises(ValueError, match="unknown variables"):
        registry.with_tolerances(variables, {"no_such_variable": (0.0, 1e-3)})
    with pytest.raises(ValueError, match="approach_rate"):
        registry.with_tolerances(variables, {"approach_rate": (-1.0, 1e-3)})
