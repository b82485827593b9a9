"""The CUDA backend of solver.simulate (solver.engine.backends, solver.engine.cuda_backend).

Without a device (CI):

* under numba-cuda's simulator, in a process of its own (``tests/helpers/cuda_sim_probe.py``), states of
  the four outcome scenes give the same results as the CPU engine, through one launch and through
  several batches; those of the generated scene of Coulomb loads and air drag with ``-m slow`` (in
  a cold cache it compiles a CPU scene kernel and the engine once more for the simulator: more than
  half of the probe's five minutes of CI's setup);
* the whole engine compiles for the device from its one Python source (to PTX, where numba-cuda
  finds NVVM);
* a missing extra, a missing device and a bad backend name are each one line; ``auto`` falls
  back to the CPU.

With a device (``-m gpu`` tests, skipped elsewhere with the reason): the full Fig. 11-13 sections in
all four scenes against the CPU engine.
"""

from __future__ import annotations

import importlib.util
import os
import pathlib
import subprocess
import sys

import numpy as np
import pytest

from rimroll import solver
from rimroll.solver.engine import backends
from tests.helpers.paths import HELPERS

HERE = HELPERS
HAS_NUMBA_CUDA = importlib.util.find_spec("numba_cuda") is not None
needs_numba_cuda = pytest.mark.skipif(not HAS_NUMBA_CUDA, reason="numba-cuda is not installed (pip install "
                                                                    "'rimroll[test]' or 'rimroll[gpu]')")
STATE = np.array([[1.2, 1.0, 35.0, 10.0], [0.9, -5.0, 35.0, 10.0]])
OUTCOME_SCENES = ["drilling", "rolling_only", "rolling_resistance", "slipping"]
"""The scenes of the Figs. 11-13 sections (tests/helpers/cuda_sim_probe.py SCENES)."""


@pytest.fixture(scope="module")
def simulated_run(tmp_path_factory) -> dict:
    """tests/helpers/cuda_sim_probe.py under the simulator: 24 states of each of the four outcome scenes (the two
    kernels a study's simulated run compiles too), and batches of 7."""
    if not HAS_NUMBA_CUDA:
        pytest.skip("numba-cuda is not installed (pip install 'rimroll[test]' or 'rimroll[gpu]')")
    return _probe(tmp_path_factory.mktemp("sim"), 24, 7, OUTCOME_SCENES)


@pytest.fixture(scope="module")
def simulated_loads(tmp_path_factory) -> dict:
    """tests/helpers/cuda_sim_probe.py under the simulator: 24 states of the scene of Coulomb loads and air drag."""
    if not HAS_NUMBA_CUDA:
        pytest.skip("numba-cuda is not installed (pip install 'rimroll[test]' or 'rimroll[gpu]')")
    return _probe(tmp_path_factory.mktemp("sim"), 24, 0, ["coulomb_air"])


@pytest.fixture(scope="module")
def simulated_rolling(tmp_path_factory) -> dict:
    """tests/cuda_sim_probe.py under the simulator: 9 states of the rolling-only scene (one kernel to
    compile, a quarter of ``simulated_run``'s cost), and batches of 4."""
    if not HAS_NUMBA_CUDA:
        pytest.skip("numba-cuda is not installed (pip install 'rimroll[test]' or 'rimroll[gpu]')")
    return _probe(tmp_path_factory.mktemp("sim"), 9, 4, ["rolling_only"])


def _probe(tmp_path, n: int, max_batch: int, labels: list[str] | None) -> dict:
    """Run tests/helpers/cuda_sim_probe.py under the simulator (the scenes ``labels``, None: all); its saved arrays."""
    out = tmp_path / "sim.npz"
    env = dict(os.environ, NUMBA_ENABLE_CUDASIM="1")
    scenes = [",".join(labels)] if labels else []
    proc = subprocess.run([sys.executable, str(HERE / "cuda_sim_probe.py"), str(out), str(n), str(max_batch), *scenes],
                          env=env, capture_output=True, text=True, timeout=1800)
    assert proc.returncode == 0, proc.stderr[-3000:]
    with np.load(out) as f:
        return {k: f[k] for k in f.files}


def _same(a: np.ndarray, b: np.ndarray, rtol: float) -> np.ndarray:
    """Elementwise: equal (NaN equals NaN), or within rtol relative."""
    a, b = np.asarray(a, float), np.asarray(b, float)
    close = np.abs(a - b) <= rtol * np.maximum(np.abs(a), np.abs(b))
    return (a == b) | (np.isnan(a) & np.isnan(b)) | close


def _compare_scenes(saved: dict, labels: list[str], kinds_reached: int) -> None:
    """Scenes ``labels`` of a probe: same outcome, status, counts; t_end and every float within 1e-12;
    a slipping scene's sample slips, and the samples reach at least ``kinds_reached`` outcomes."""
    from rimroll.solver.engine.outputs import OUTPUTS

    assert str(saved["device"]) == f"cuda ({backends.SIMULATOR_NAME})"
    assert sorted({k.split("/")[0] for k in saved if k.count("/") == 2}) == sorted(labels)
    kinds = set()
    for label in labels:
        cpu = {o.name: saved[f"{label}/cpu/{o.name}"] for o in OUTPUTS}
        gpu = {name: saved[f"{label}/cuda/{name}"] for name in cpu}
        for name in (o.name for o in OUTPUTS if o.dtype != "float64"):
            np.testing.assert_array_equal(gpu[name], cpu[name], err_msg=f"{label}: {name}")
        for name in (o.name for o in OUTPUTS if o.dtype == "float64"):
            ok = _same(gpu[name], cpu[name], 1e-12)
            assert ok.all(), f"{label}: {name} differs at {np.flatnonzero(~ok)}: {gpu[name][~ok]} vs {cpu[name][~ok]}"
        kinds |= set(np.unique(cpu["outcome"]).tolist())
        if label != "rolling_only":
            assert cpu["slip_phases"].max() > 0, f"{label}: no state slipped; the sample checks no slipping phase"
    assert len(kinds) >= kinds_reached, f"the sample reaches only outcomes {kinds}"


@pytest.mark.slow  # ~170 s of simulator compiles (docs/contributing.md: the test suite's time)
def test_simulator_gives_the_cpu_engines_results_in_every_scene(simulated_run):
    """A few dozen states per outcome scene: same outcome, status, counts; t_end and every float within 1e-12."""
    _compare_scenes(simulated_run, OUTCOME_SCENES, 3)


@pytest.mark.slow
def test_simulator_gives_the_cpu_engines_results_under_coulomb_loads_and_air_drag(simulated_loads):
    """The same for the generated scene kernel of Coulomb resistances and air drag (Sect. 5.3's load terms)."""
    _compare_scenes(simulated_loads, ["coulomb_air"], 2)  # in and out: the loads end every run


def test_simulator_batches_equal_one_launch(simulated_rolling):
    """In the rolling-only scene the simulated device gives the CPU engine's results, and batches of 4
    states on two alternating streams give the rows of one launch, in order."""
    saved = simulated_rolling
    from rimroll.solver.engine.kernels import RF_T_END, RI_N_STEPS, RI_OUTCOME

    _compare_scenes(saved, ["rolling_only"], 2)
    res_f, res_i = saved["batched/res_f"], saved["batched/res_i"]
    assert np.isfinite(res_f[:, RF_T_END]).all() and (res_i[:, RI_N_STEPS] >= 0).all()  # every row written
    np.testing.assert_array_equal(res_i[:, RI_OUTCOME], saved["rolling_only/cuda/outcome"])
    np.testing.assert_array_equal(res_f[:, RF_T_END], saved["rolling_only/cuda/t_end"])


def test_batch_size_from_free_memory():
    """Two batches fit in MEMORY_FRACTION of the free memory; big inputs overlap; a section is one launch."""
    pytest.importorskip("numba_cuda")
    from rimroll.solver.engine import cuda_backend as cb

    gib = 2**30
    assert cb.batch_size(86_400, 70 * gib) == 86_400  # a section: one launch
    assert cb.batch_size(8_640_000, 70 * gib) == 2_160_000  # 4 overlapping batches
    small = cb.batch_size(8_640_000, 0.1 * gib)
    assert 2 * small * cb.BYTES_PER_STATE <= cb.MEMORY_FRACTION * 0.1 * gib < 2 * (small + 1) * cb.BYTES_PER_STATE
    assert cb.batch_size(100, float("inf")) == 100  # the simulator reports unlimited memory
    assert cb.batch_size(100, 70 * gib, max_batch=7) == 7
    with pytest.raises(backends.BackendUnavailable, match="MiB free"):
        cb.batch_size(100, 100.0)


def test_bad_backend_name_is_a_value_error():
    with pytest.raises(ValueError, match="`backend` must be one of cpu, cuda, auto; got 'gpu'"):
        solver.simulate(STATE, solver.Params(), t_max=0.1, backend="gpu")


def test_missing_extra_is_one_line_and_auto_falls_back(monkeypatch):
    """Without numba-cuda: 'cuda' names the extra in one line; 'auto' runs on the CPU, same results."""
    real = importlib.util.find_spec
    monkeypatch.setattr(backends.importlib.util, "find_spec",
                        lambda name, *a: None if name == "numba_cuda" else real(name, *a))
    with pytest.raises(backends.BackendUnavailable) as err:
        solver.simulate(STATE, solver.Params(), t_max=0.1, backend="cuda")
    message = str(err.value)
    assert "\n" not in message and "rimroll[gpu]" in message and "numba-cuda" in message
    assert backends.resolve("auto").name == "cpu"
    auto = solver.simulate(STATE, solver.Params(), t_max=0.5, backend="auto")
    cpu = solver.simulate(STATE, solver.Params(), t_max=0.5)
    np.testing.assert_array_equal(auto["t_end"], cpu["t_end"])


def _has_device() -> bool:
    return HAS_NUMBA_CUDA and backends.cuda_device_count() > 0 and not backends.simulated()


@needs_numba_cuda
@pytest.mark.skipif(_has_device(), reason="a CUDA device is present: there is no missing device to report")
def test_missing_device_is_one_line():
    with pytest.raises(backends.BackendUnavailable) as err:
        solver.simulate(STATE, solver.Params(), t_max=0.1, backend="cuda")
    message = str(err.value)
    assert "\n" not in message and "no usable CUDA device" in message
    assert backends.resolve("auto") == backends.cpu()


def _study(*args, env=None) -> subprocess.CompletedProcess:
    return subprocess.run([sys.executable, "-m", "rimroll.study", *args], capture_output=True, text=True, timeout=900,
                          env=dict(os.environ, **(env or {})))


@needs_numba_cuda
@pytest.mark.skipif(_has_device(), reason="a CUDA device is present: there is no missing device to report")
def test_study_run_without_device_exits_with_one_line(tmp_path):
    for args in (["--set", "backend=cuda"], ["--backend", "cuda"]):
        proc = _study("run", "fig11", "--quick", "--out", str(tmp_path), *args)
        assert proc.returncode == 2, proc.stderr
        lines = proc.stderr.strip().splitlines()
        assert len(lines) == 1 and lines[0].startswith("study: error: backend 'cuda': no usable CUDA device")
    assert not list(tmp_path.glob("*.nc"))
    proc = _study("run", "fig8", "--quick", "--out", str(tmp_path), "--backend", "cuda")
    assert proc.returncode == 2 and "does not run solver.simulate" in proc.stderr
    proc = _study("run", "fig11", "--quick", "--out", str(tmp_path), "--set", "backend=gpu")
    assert proc.returncode == 2 and "allowed backends are cpu, cuda, auto" in proc.stderr


@needs_numba_cuda
@pytest.mark.slow  # two subprocess runs whose simulator compiles four scene kernels (~120 s at load 4)
def test_study_run_on_the_simulated_device_matches_the_cpu_run(tmp_path):
    """``study run fig11 --backend cuda`` under the simulator: the CPU run's numbers, and the backend and
    device in the file's attributes."""
    from rimroll.study import io

    sets = ["--quick", "--set", "n_beta=30", "--set", "n_omega1=8", "--set", "method=dp5", "--no-progress"]
    proc = _study("run", "fig11", *sets, "--backend", "cuda", "--out", str(tmp_path / "gpu"),
                  env={"NUMBA_ENABLE_CUDASIM": "1"})
    assert proc.returncode == 0, proc.stderr
    proc = _study("run", "fig11", *sets, "--out", str(tmp_path / "cpu"))
    assert proc.returncode == 0, proc.stderr
    gpu, cpu = io.open_result(tmp_path / "gpu" / "fig11.nc"), io.open_result(tmp_path / "cpu" / "fig11.nc")
    assert gpu.attrs["setting_backend"] == "cuda" and cpu.attrs["setting_backend"] == "cpu"
    assert gpu.attrs["source"].endswith(f"; backend cuda on {backends.SIMULATOR_NAME}")
    # the storage chunks do not follow the compute chunks (about a million values: here the whole cube)
    assert gpu["outcome"].encoding["chunksizes"] == cpu["outcome"].encoding["chunksizes"] == (4, 30, 8)
    for name in ("outcome", "status", "t_end", "f2_min", "slip_time", "boundary_type"):
        np.testing.assert_array_equal(gpu[name].values, cpu[name].values, err_msg=name)


def test_a_device_run_computes_a_section_per_chunk():
    """With the cuda backend a chunk is a whole section (one launch); on the CPU the study's own chunking."""
    from rimroll.study import registry
    from rimroll.study.plan import make_plan

    grid = {"n_beta": 30, "n_omega1": 8}
    assert make_plan(registry.get("fig11"), True, {**grid, "backend": "cuda"}, local=False).nc_chunks == (1, 30, 8)
    assert make_plan(registry.get("fig11"), True, grid).nc_chunks == (1, 24, 8)  # the study's CPU chunking


def test_auto_records_the_backend_in_the_file(tmp_path):
    """Where 'auto' finds no device it runs on the CPU, and the file says so (setting and source)."""
    if _has_device():
        pytest.skip("a CUDA device is present: auto picks it (the gpu tests check that)")
    from rimroll.study import io

    proc = _study("run", "outcome-cube", "--quick", "--out", str(tmp_path), "--set", "n_beta=3", "--set",
                  "n_omega1=3", "--set", "mu=1", "--set", "k_r=0", "--set", "k_d=0", "--set", "omega2=65",
                  "--backend", "auto")
    assert proc.returncode == 0, proc.stderr
    ds = io.open_result(tmp_path / "outcome-cube.nc")
    assert ds.attrs["setting_backend"] == "cpu"
    assert ds.attrs["source"].endswith("; backend cpu")


# ----------------------------------------------------------------------------- device compilation
ENGINE_MODULES = ("physics/rolling", "physics/slipping", "physics/switching", "physics/kinematics", "engine/rules",
                  "physics/flight", "engine/system", "engine/stepper", "engine/events", "engine/kernels")
"""The solver modules whose compiled functions the device kernels reach."""


@needs_numba_cuda
def test_the_engine_calls_only_numpy_functions_the_device_lowers():
    """Every ``np.<f>(...)`` call in a compiled function of the engine (``@kernel``; the CPU chunk
    driver run_scene and its new_work, whose work arrays the device launcher replaces, aside) is a
    ufunc numba-cuda lowers on scalars, or one of the loops solver.engine.cuda_backend adds: a new
    numpy call in the engine that the device cannot compile fails here, without the CUDA compiler."""
    import ast

    from numba.cuda import ufuncs

    from rimroll.solver.engine import cuda_backend

    lowered = {u.__name__ for u in ufuncs.ufunc_db()} | {u.__name__ for u in cuda_backend.UFUNC_LOOPS}
    lowered |= {"abs"}  # np.abs is np.absolute
    # numpy scalar types called as casts (np.int64(0)): numba-cuda lowers every call of a number class
    # (numba_cuda/numba/cuda/cpython/builtins.py, ``@lower(types.NumberClass, types.Any)``)
    lowered |= {t.__name__ for t in (np.int64, np.int32, np.float64)}
    root = pathlib.Path(solver.__file__).resolve().parent
    calls = {}
    for name in ENGINE_MODULES:
        tree = ast.parse((root / f"{name}.py").read_text())
        for fn in (n for n in tree.body if isinstance(n, ast.FunctionDef) and n.name not in ("run_scene", "new_work")
                   and any("kernel" in ast.unparse(d) for d in n.decorator_list)):
            for node in ast.walk(fn):
                if (isinstance(node, ast.Call) and isinstance(node.func, ast.Attribute)
                        and isinstance(node.func.value, ast.Name) and node.func.value.id == "np"):
                    calls.setdefault(node.func.attr, set()).add(f"{name}.{fn.name}")
    assert {"sqrt", "isfinite", "sin", "hypot"} <= set(calls)  # the scan sees the engine
    missing = {f: sorted(where) for f, where in calls.items() if f not in lowered}
    assert not missing, f"numpy calls the device cannot compile: {missing}"


def _nvvm_reason() -> str | None:
    """Why the engine cannot be compiled to PTX here (None if it can): numba-cuda needs the CUDA
    compiler libraries (NVVM, libdevice, NVRTC), which rimroll[gpu] installs; rimroll[test] does not
    (they are 130 MB of wheels), so CI checks the source with the static test above instead."""
    if not HAS_NUMBA_CUDA:
        return "numba-cuda is not installed"
    code = ("from numba.cuda.cudadrv.nvvm import NVVM; NVVM(); "
            "from numba.cuda.cuda_paths import get_cuda_paths; get_cuda_paths()")
    proc = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=120)
    if proc.returncode == 0:
        return None
    return ("numba-cuda finds no CUDA compiler libraries (NVVM, libdevice, NVRTC; pip install 'rimroll[gpu]'): "
            + (proc.stderr.strip().splitlines() or ["?"])[-1][:160])


PTX_SCRIPT = r'''
import sys, time
import numba.cuda.dispatcher as dispatcher
from numba.cuda.cudadrv import nvrtc

class Device:  # what numba-cuda asks of the device while compiling device functions: an sm_90 (H100)
    compute_capability = (9, 0)
dispatcher.get_current_device = lambda: Device()
nvrtc.get_supported_ccs = lambda: ((9, 0),)  # NVRTC is asked only for the architectures it knows
from numba import cuda
from rimroll.solver.engine import cuda_backend, scenes
t0 = time.perf_counter()
scene = scenes.named(sys.argv[1])
ptx, _ = cuda.compile_ptx(cuda_backend.launcher(scene, sys.argv[2]), cuda_backend.SIGNATURE, cc=(9, 0))
open(sys.argv[3], "w").write(ptx)
print(f"{time.perf_counter() - t0:.1f}")
'''


def _compile_ptx(tmp_path, scene: str, method: str) -> str:
    reason = _nvvm_reason()
    if reason:
        pytest.skip(reason)
    out = tmp_path / f"scene{scene}_{method}.ptx"
    proc = subprocess.run([sys.executable, "-c", PTX_SCRIPT, str(scene), method, str(out)], capture_output=True,
                          text=True, timeout=1800)
    assert proc.returncode == 0, proc.stderr[-3000:]
    return out.read_text()


def _check_ptx(ptx: str, scene: str, method: str) -> None:
    from rimroll.solver.engine import scenes

    assert ".visible .entry" in ptx and f"launch_{scenes.named(scene).kernel}_{method}" in ptx
    assert ".f64" in ptx and ".local" in ptx  # float64 arithmetic, per-thread local work arrays
    # the tableau is baked in: its first nonzero coefficient appears as a float64 immediate or constant
    assert ".const" in ptx or "0d3FC999999999999A" in ptx  # 1/5 = A[1, 0] of DP5


def test_the_engine_compiles_for_the_device_from_its_one_source(tmp_path):
    """The hybrid dissipative scene (rolling, slipping, switching, every rule) compiles to PTX."""
    ptx = _compile_ptx(tmp_path, "drilling", "dp5")  # slipping + drilling resistance: the hybrid dissipative kernel
    _check_ptx(ptx, "drilling", "dp5")


@pytest.mark.slow
@pytest.mark.parametrize("method", ["dp5", "dop853"])
@pytest.mark.parametrize("scene", ["rolling_only", "rolling_only+drilling", "slipping", "drilling"])  # the 4 kernels
def test_every_scene_and_method_compiles_for_the_device(tmp_path, scene, method):
    ptx = _compile_ptx(tmp_path, scene, method)
    _check_ptx(ptx, scene, method)


# ----------------------------------------------------------------------------- on a device
gpu = pytest.mark.gpu


def _device_or_skip():
    if not HAS_NUMBA_CUDA:
        pytest.skip("numba-cuda is not installed (pip install 'rimroll[gpu]')")
    try:
        name = backends.cuda_device()
    except backends.BackendUnavailable as exc:
        pytest.skip(str(exc))
    if name == backends.SIMULATOR_NAME:
        pytest.skip("numba-cuda runs its simulator (NUMBA_ENABLE_CUDASIM): the gpu tests need a device")
    return name


SECTIONS = {"fig11": 35.0, "fig12": 65.0, "fig13": 105.0}  # omega2 [1/s] of the sections (workflows/outcome_grids.py)


@gpu
@pytest.mark.parametrize("figure", sorted(SECTIONS))
def test_full_section_matches_the_cpu_engine(figure):
    """Fig. 11-13 sections (240 x 360 states) in all four scenes: outcomes identical on >= 99.99% of
    states, every difference a boundary state (a neighbour has another outcome on the CPU), t_end
    within 1e-9 relative where the outcomes agree. (solver only: runs without the study layer's
    dependencies.)"""
    _device_or_skip()
    from tests.helpers.cuda_sim_probe import OMEGA3, SCENES

    beta, omega1 = np.linspace(0.8, 1.8, 240), np.linspace(-20.0, 20.0, 360)
    B, W1 = np.meshgrid(beta, omega1, indexing="ij")
    states = np.stack([B, W1, np.full_like(B, SECTIONS[figure]), np.full_like(B, OMEGA3)], axis=-1)
    for label, (changes, t_max) in SCENES.items():
        params = solver.Params(**changes)
        kw = dict(t_max=t_max, rtol=1e-8, atol=1e-10, method="dp5")
        cpu = solver.simulate(states, params, **kw)
        dev = solver.simulate(states, params, **kw, backend="cuda")
        differ = dev["outcome"] != cpu["outcome"]
        assert differ.mean() <= 1e-4, f"{figure} {label}: {differ.sum()} of {differ.size} outcomes differ"
        o = np.pad(cpu["outcome"], 1, mode="edge")
        boundary = ((o[1:-1, 1:-1] != o[:-2, 1:-1]) | (o[1:-1, 1:-1] != o[2:, 1:-1])
                    | (o[1:-1, 1:-1] != o[1:-1, :-2]) | (o[1:-1, 1:-1] != o[1:-1, 2:]))
        assert boundary[differ].all(), f"{figure} {label}: differing states off the boundaries: " \
                                       f"{np.argwhere(differ & ~boundary).tolist()}"
        same = ~differ
        ok = _same(dev["t_end"][same], cpu["t_end"][same], 1e-9)
        assert ok.all(), f"{figure} {label}: t_end differs by more than 1e-9 on {(~ok).sum()} states"
        np.testing.assert_array_equal(dev["status"][same], cpu["status"][same])


@gpu
def test_auto_picks_the_device_and_batches_agree():
    """On a device 'auto' is 'cuda'; an input in many small batches equals one launch."""
    name = _device_or_skip()
    assert backends.resolve("auto") == backends.Backend("cuda", name)
    from rimroll.solver.engine import cuda_backend
    from rimroll.solver.engine.kernels import Limits
    from rimroll.solver.engine.scenes import scene_of
    from rimroll.solver.physics.switching import default_tolerances

    rng = np.random.default_rng(3)
    states = np.stack([rng.uniform(0.8, 1.8, 5000), rng.uniform(-20, 20, 5000), np.full(5000, 65.0),
                       np.full(5000, 10.0)], -1)
    params = solver.Params(mu=1.0)
    one = solver.simulate(states, params, backend="cuda")
    res_f = np.full((5000, solver.engine.kernels.N_RF), np.nan)
    res_i = np.full((5000, solver.engine.kernels.N_RI), -1, dtype=np.int64)
    cuda_backend.run(scene_of(params), "dp5", states, params.as_array(),
                     Limits(20.0, 1e-8, 1e-10, 1_000_000, 10_000, True), default_tolerances(), res_f, res_i,
                     max_batch=777)
    np.testing.assert_array_equal(res_i[:, solver.engine.kernels.RI_OUTCOME], one["outcome"])
    np.testing.assert_array_equal(res_f[:, solver.engine.kernels.RF_T_END], one["t_end"])
