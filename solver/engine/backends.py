"""Where ``solver.simulate`` runs: ``cpu`` (threads over the compiled CPU kernels) or ``cuda``
(one GPU thread per trajectory, ``solver.engine.cuda_backend``), or ``auto`` (the GPU when one is usable).

Both backends run the same rules, physics and integrator, compiled from the same Python source
(docs/outcome-engine.md, "Backends"). ``cuda`` needs the optional extra ``rimroll[gpu]``
(numba-cuda) and a CUDA device; without either, :func:`resolve` raises
:class:`BackendUnavailable` with one line saying which is missing. Nothing here imports
numba-cuda until a backend other than ``cpu`` is asked for.
"""

from __future__ import annotations

import dataclasses
import importlib.util
import os
import threading

BACKENDS = ("cpu", "cuda", "auto")
"""Names accepted by ``solver.simulate(..., backend=...)`` and the studies' ``backend`` setting."""
SIMULATOR_NAME = "CUDA simulator"
"""Device name reported under numba-cuda's simulator (``NUMBA_ENABLE_CUDASIM=1``)."""
GPU_EXTRA = "pip install 'rimroll[gpu]'"
DEVICE_ENV = "RIMROLL_CUDA_DEVICE"
"""Environment variable: index of the CUDA device this process computes on (taken modulo the
devices it sees; default: numba-cuda's current device, 0). The dask fan-out sets it per worker."""
_bound = threading.local()


class BackendUnavailable(RuntimeError):
    """The backend asked for cannot run here: its optional extra or its device is missing (one line)."""


@dataclasses.dataclass(frozen=True)
class Backend:
    """A resolved backend: ``name`` is 'cpu' or 'cuda'; ``device`` says what runs it (for provenance)."""

    name: str
    device: str

    def describe(self) -> str:
        """'cuda (NVIDIA H100 80GB HBM3)', 'cpu (2 cores)': the words a result file records."""
        return f"{self.name} ({self.device})"


def check_name(backend) -> str:
    """``backend`` if it is one of :data:`BACKENDS`; ValueError naming the allowed ones otherwise."""
    if not isinstance(backend, str) or backend not in BACKENDS:
        raise ValueError(f"`backend` must be one of {', '.join(BACKENDS)}; got {backend!r}")
    return backend


def cpu() -> Backend:
    return Backend("cpu", f"{os.cpu_count() or 1} cores")


def numba_cuda():
    """numba-cuda's ``numba.cuda`` module; BackendUnavailable when the extra is not installed."""
    from rimroll.solver import _jit

    if _jit._DISABLE:
        raise BackendUnavailable("backend 'cuda' compiles the engine's kernels for the GPU, but RIMROLL_NO_JIT "
                                 "is set (pure-Python kernels); unset it or use backend 'cpu'")
    if importlib.util.find_spec("numba_cuda") is None:
        raise BackendUnavailable(f"backend 'cuda' needs the optional extra rimroll[gpu] (numba-cuda), which is "
                                 f"not installed: {GPU_EXTRA}")
    from numba import cuda

    return cuda


def simulated() -> bool:
    """Whether numba-cuda runs its simulator (``NUMBA_ENABLE_CUDASIM=1``) instead of a device."""
    from numba import config

    return bool(config.ENABLE_CUDASIM)


def cuda_device() -> str:
    """Name of the CUDA device this thread would use; BackendUnavailable without the extra or a device."""
    cuda = numba_cuda()
    if simulated():
        return SIMULATOR_NAME
    if not cuda.is_available():
        raise BackendUnavailable(f"backend 'cuda': no usable CUDA device ({_driver_error(cuda)}); "
                                 "use backend 'cpu' or 'auto'")
    _bind(cuda)
    name = cuda.get_current_device().name
    return name.decode() if isinstance(name, bytes) else str(name)


def _bind(cuda) -> None:
    """Make the device of :data:`DEVICE_ENV` current in this thread (once per thread)."""
    index = os.environ.get(DEVICE_ENV)
    if index is None or getattr(_bound, "index", None) == index:
        return
    try:
        device = int(index) % len(cuda.gpus)
    except ValueError:
        raise BackendUnavailable(f"{DEVICE_ENV}={index!r} must be a device index (an integer)") from None
    cuda.select_device(device)
    _bound.index = index


def worker_device() -> str:
    """What this process computes on with backend 'cuda', as a result file records it."""
    return cuda_device()


def cuda_device_count() -> int:
    """Number of CUDA devices visible to this process (0 without the extra or a driver; 1 simulated)."""
    try:
        cuda = numba_cuda()
    except BackendUnavailable:
        return 0
    if simulated():
        return 1
    return len(cuda.gpus) if cuda.is_available() else 0


def _driver_error(cuda) -> str:
    """One line on why numba-cuda found no device (the driver's own words where it gives them)."""
    try:
        from numba.cuda.cudadrv.driver import driver

        driver.get_device_count()
    except Exception as exc:  # noqa: BLE001  whatever the driver says, it is the reason
        text = " ".join(str(exc).split()).rstrip(": ")
        return text[:200] or type(exc).__name__
    return "the driver reports no device"


def resolve(backend: str = "cpu") -> Backend:
    """The backend that ``backend`` names here: 'cpu'; 'cuda' (BackendUnavailable when the extra or
    the device is missing); 'auto': 'cuda' when a real device is usable, else 'cpu' (never the
    simulator, which is for tests)."""
    check_name(backend)
    if backend == "cpu":
        return cpu()
    if backend == "cuda":
        return Backend("cuda", cuda_device())
    try:
        device = cuda_device()
    except BackendUnavailable:
        return cpu()
    return cpu() if device == SIMULATOR_NAME else Backend("cuda", device)
