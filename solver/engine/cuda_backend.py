"""The CUDA backend of ``solver.simulate``: one GPU thread per trajectory, the same engine source.

Imported only when ``backend="cuda"`` is resolved (``solver.engine.backends``); it needs numba-cuda
(the optional extra ``rimroll[gpu]``).

**One source.** The kernel of a (scene, method) is a small launcher (:func:`launcher`) that gives
each thread its work arrays and calls ``kernels.trajectory`` with the scene's flags as literals,
the very function (and flags) the CPU engine's scene kernels run. numba-cuda compiles every compiled function it
reaches (the
rules, the phase systems, the stepper, the locator, the physics of ``rolling``/``slipping``/
``switching``/``kinematics``) from its Python source for the device, as it does for any
``numba.njit`` function called from a CUDA kernel; there is no second copy of any equation.
What differs on the device:

* the work arrays (``W``, ``K``, ``Q``, ``G``, event signs and flags) are per-thread local arrays
  (registers / local memory), zeroed at the start of each trajectory;
* the method's tableau (``A``, ``E``, ``P``) and its integers are compile-time constants of
  the kernel (constant memory);
* float64 throughout, no fastmath (the device may contract a*b+c into one fused multiply-add, and
  its libdevice sin/cos/sqrt round like the host's to within an ulp or so: hence "t_end within
  1e-9 relative" against the CPU engine on a device, docs/outcome-engine.md).

numba-cuda lowers only some numpy ufuncs on scalars; the engine's source also calls ``np.sqrt``,
``np.abs``, ``np.isfinite`` and ``np.nextafter``, whose float64 loops are added here
(:func:`register_ufuncs`) as numba-cuda's own lowering of ``math.sqrt``, ``math.fabs``,
``math.isfinite`` and ``math.nextafter`` (libdevice).

**Transfers.** :func:`run` streams the states through the device in batches sized from the free
device memory (:func:`batch_size`), double-buffered on two CUDA streams with pinned host
buffers that are kept for the next call; a batch is one launch, and an input of up to
:data:`OVERLAP_ABOVE` states (a whole outcome section) is one batch. One GPU is used per
process (the current device of numba-cuda); calls from several threads take turns.

Under numba-cuda's simulator (``NUMBA_ENABLE_CUDASIM=1``, for tests without a device) the same
launcher runs in Python threads; each simulated thread then runs the CPU machine code of the
trajectory kernel on its own local arrays, so the simulator checks the launcher, the batching and
the result layout; ``tests/solver/engine/test_cuda_backend.py`` checks the device compilation of the whole
engine separately (to PTX, where numba-cuda finds the CUDA compiler libraries, and everywhere a
static check that the engine calls only numpy functions the device lowers).
"""

from __future__ import annotations

import math
import threading

import numpy as np
from numba import cuda, types

from rimroll.solver.engine import kernels, rosenbrock, scene_code, system, tableaus
from rimroll.solver.engine.backends import simulated
from rimroll.solver.engine.kernels import N_G, N_RF, N_RI, N_W
from rimroll.solver.engine.scenes import Scene
from rimroll.solver.engine.system import N_EVENTS, N_MAX
from rimroll.solver.engine.tableaus import TABLEAUS

SIMULATED = simulated()

THREADS_PER_BLOCK = 128
"""Threads per block of a launch (one trajectory each)."""
MAX_REGISTERS = None
"""Cap on registers per thread passed to the device compiler (None: its own choice). The whole
engine inlines into one kernel of ~255 registers on sm_90; a cap trades spills for occupancy
(``benchmarks/gpu.py --max-registers``)."""
MEMORY_FRACTION = 0.25
"""Fraction of the free device memory the state and result buffers of one call may take (the
rest is left to the kernel's local memory and to other users of the device)."""
OVERLAP_ABOVE = 1_000_000
"""Inputs above this many states are split into at least :data:`OVERLAP_BATCHES` batches, so that
the transfers of one batch overlap the computation of the next; a section is one launch."""
OVERLAP_BATCHES = 4
BYTES_PER_STATE = 8 * (4 + N_RF + N_RI)
"""Device (and pinned host) bytes per state: the initial state and its two result rows."""

UFUNC_LOOPS = {  # numpy ufunc: (loop, math function whose numba-cuda lowering implements it)
    np.sqrt: ("d->d", math.sqrt),
    np.absolute: ("d->d", math.fabs),
    np.isfinite: ("d->?", math.isfinite),
    np.nextafter: ("dd->d", math.nextafter),
}


def register_ufuncs() -> None:
    """Add the float64 loops of :data:`UFUNC_LOOPS` to numba-cuda's table of scalar ufuncs.

    numba-cuda types these ufuncs but has no lowering for them on scalars (its table holds the
    trigonometric ones, hypot, arctan2, maximum, ...); each added loop calls numba-cuda's own
    implementation of the math-module function. Idempotent.
    """
    from numba.cuda import ufuncs

    def via(fn):
        def lower(context, builder, sig, args):
            return context.get_function(fn, sig)(builder, args)

        return lower

    table = ufuncs.ufunc_db()  # numba-cuda's (cached) table {ufunc: {loop: lowering}}
    for ufunc, (loop, fn) in UFUNC_LOOPS.items():
        table.setdefault(ufunc, {}).setdefault(loop, via(fn))


if not SIMULATED:
    try:
        register_ufuncs()
    except (ImportError, AttributeError, TypeError) as exc:  # a numba-cuda without that table
        from rimroll.solver.engine.backends import BackendUnavailable

        raise BackendUnavailable(f"backend 'cuda': this numba-cuda has no table of scalar ufuncs to extend "
                                 f"({type(exc).__name__}: {exc}); install numba-cuda >= 0.30") from None

    @cuda.jit(device=True)
    def native(a):
        """An array argument as the trajectory kernel takes it (on the device: itself)."""
        return a
else:
    def native(a):
        """An array argument as the trajectory kernel takes it (simulated: the numpy array under
        the simulator's wrapper, so that the CPU machine code accepts it)."""
        return np.asarray(a)


def launcher(scene: Scene, method: str):
    """The Python source of the kernel of a scene and method: one trajectory per thread.

    ``launch(states, m, p, t_max, rtol, atol, max_steps, max_switches, switches, switch_tol, float_results,
    int_results)`` (the
    fields of ``kernels.Limits`` as scalars, its two booleans as the bits of ``switches``: 1 periodic,
    2 stiff_slips): thread k < m integrates row k of ``states`` (m, 4) and
    writes rows k of ``float_results`` (m, N_RF) and ``int_results`` (m, N_RI), exactly as the CPU scene kernels
    do for one row.
    """
    trajectory = kernels.trajectory  # the CPU engine's trajectory body
    slips = scene.slips  # a compile-time constant, as in the scene kernels
    tab = TABLEAUS[method]
    A, E, P = tab.A, tab.E, tab.P  # constants of the kernel
    n_stages, err_mode, error_order = tab.n_stages, tab.err_mode, tab.error_order
    n_dense, n_poly = A.shape[0], P.shape[1]
    f64, i64, b1 = types.float64, types.int64, types.boolean
    Method, Limits, Work, Model = tableaus.Method, kernels.Limits, kernels.Work, system.Model
    has_load = bool(scene.loads)  # the scene's load terms come from its generated module (scene_code)
    terms = scene_code.module(scene) if has_load else None
    # the Rosenbrock arrays of slip phases (kernels.Work): 1 x 1 where the scene never slips
    n_ro, n_j = (rosenbrock.N_ROWS, N_MAX) if slips else (1, 1)

    def launch(states, m, p, t_max, rtol, atol, max_steps, max_switches, switches, switch_tol, float_results,
               int_results):
        k = cuda.grid(1)
        if k >= m:
            return
        W = cuda.local.array((N_W, N_MAX), f64)
        K = cuda.local.array((n_dense, N_MAX), f64)
        Q = cuda.local.array((N_MAX, n_poly), f64)
        G = cuda.local.array((N_G, N_EVENTS), f64)
        sign = cuda.local.array(N_EVENTS, i64)
        R = cuda.local.array((n_ro, n_j), f64)
        J = cuda.local.array((n_j, n_j), f64)
        LU = cuda.local.array((n_j, n_j), f64)
        piv = cuda.local.array(n_j, i64)
        search = cuda.local.array(N_EVENTS, b1)
        active = cuda.local.array((2, N_EVENTS), b1)
        for i in range(N_MAX):
            for r in range(N_W):
                W[r, i] = 0.0
            for r in range(n_dense):
                K[r, i] = 0.0
            for q in range(n_poly):
                Q[i, q] = 0.0
        for e in range(N_EVENTS):
            sign[e] = 0
            search[e] = False
            active[0, e] = True
            active[1, e] = True
            for r in range(N_G):
                G[r, e] = 0.0
        work = Work(W, K, Q, G, sign, search, active, R, J, LU, piv)
        method = Method(A, E, P, n_stages, err_mode, error_order)
        limits = Limits(t_max, rtol, atol, max_steps, max_switches, (switches & 1) != 0, (switches & 2) != 0)
        if has_load:  # a constant of the kernel, as slips: numba compiles one branch
            model = Model(native(p), terms.load, False)
        else:
            model = Model(native(p), None, False)
        if slips:  # a constant of the kernel: numba compiles one of the two calls
            trajectory(native(switch_tol), native(states[k]), model, method, limits, work,
                       native(float_results[k]), native(int_results[k]))
        else:  # rolling only: no switching tolerances, no slipping code
            trajectory(None, native(states[k]), model, method, limits, work, native(float_results[k]),
                       native(int_results[k]))

    launch.__qualname__ = launch.__name__ = f"launch_{scene.kernel}_{method}"
    return launch


SIGNATURE = (types.float64[:, ::1], types.int64, types.float64[::1], types.float64, types.float64, types.float64,
             types.int64, types.int64, types.int64, types.float64[::1], types.float64[:, ::1], types.int64[:, ::1])
"""Argument types of a launcher (the kernel is compiled for these only)."""

_KERNELS: dict = {}
_LOCK = threading.RLock()  # one call at a time uses the device (and the kept buffers) of this process


def kernel(scene: Scene, method: str):
    """The kernel of a scene and method (numba-cuda compiles it at its first launch in this process;
    :func:`compile_kernel` does that ahead of time)."""
    key = (scene.flags, tuple(t.name for t in scene.loads), method, MAX_REGISTERS)
    with _LOCK:
        if key not in _KERNELS:
            options = {} if MAX_REGISTERS is None or SIMULATED else {"max_registers": MAX_REGISTERS}
            _KERNELS[key] = cuda.jit(**options)(launcher(scene, method))
        return _KERNELS[key]


def compile_kernel(scene: Scene, method: str) -> None:
    """Compile the kernel of a scene and method for this process's device now (no launch)."""
    k = kernel(scene, method)
    if not SIMULATED:
        with _LOCK:
            k.compile(SIGNATURE)


def _announce(scene: Scene, method: str) -> None:
    """One notice (logging, INFO, logger ``rimroll.solver...``) before a kernel's first compile in this process:
    a long silence otherwise."""
    import logging

    name = scene.kernel.removeprefix("scene_")
    logging.getLogger(__name__).info("compiling the CUDA kernel of the %s scene (%s) for the device, once per "
                                     "process: about a minute", name, method)


def batch_size(m: int, free_bytes: float, max_batch: int | None = None) -> int:
    """States per launch for an input of m states with ``free_bytes`` of free device memory.

    Two batches are in flight at a time (double buffering), and together they take at most
    MEMORY_FRACTION of the free memory; an input above OVERLAP_ABOVE states is cut into at least
    OVERLAP_BATCHES batches so that transfers overlap computation. ``max_batch`` caps it (tests).
    """
    fits = MEMORY_FRACTION * free_bytes / (2 * BYTES_PER_STATE)
    batch = m if not math.isfinite(fits) else min(m, int(fits))
    if m > OVERLAP_ABOVE:
        batch = min(batch, -(-m // OVERLAP_BATCHES))
    if max_batch is not None:
        batch = min(batch, int(max_batch))
    if batch < 1:
        from rimroll.solver.engine.backends import BackendUnavailable

        raise BackendUnavailable(f"backend 'cuda': the device has {free_bytes / 2**20:.0f} MiB free, too little "
                                 f"for even one state ({BYTES_PER_STATE} bytes); free device memory or use 'cpu'")
    return batch


def _configure(k, blocks: int, stream):
    """The launch of kernel k on ``blocks`` blocks in ``stream``. A small input is a small grid by
    nature, so numba-cuda's low-occupancy warning (fewer than 128 blocks) is not passed on."""
    import warnings

    with warnings.catch_warnings():  # process-wide for an instant; this runs under _LOCK
        warnings.filterwarnings("ignore", message=r"Grid size \d+ will likely result in GPU under-utilization")
        return k[blocks, THREADS_PER_BLOCK, stream]


class _Slot:
    """One of the two in-flight batches: a stream, pinned host buffers and device buffers."""

    def __init__(self, capacity: int):
        self.capacity = capacity
        self.stream = cuda.stream()
        self.h_states = cuda.pinned_array((capacity, 4))
        self.h_f = cuda.pinned_array((capacity, N_RF))
        self.h_i = cuda.pinned_array((capacity, N_RI), dtype=np.int64)
        self.d_states = cuda.device_array((capacity, 4), stream=self.stream)
        self.d_f = cuda.device_array((capacity, N_RF), stream=self.stream)
        self.d_i = cuda.device_array((capacity, N_RI), dtype=np.int64, stream=self.stream)
        self.rows = None  # (lo, hi) of the batch whose results are on their way back


_SLOTS: list = []  # kept between calls: pinned allocations cost milliseconds


def _slots(capacity: int) -> list:
    """Two slots of at least ``capacity`` states (reused, or grown)."""
    global _SLOTS
    if not _SLOTS or _SLOTS[0].capacity < capacity:
        _SLOTS = []  # free the old buffers first
        _SLOTS = [_Slot(capacity), _Slot(capacity)]
    return _SLOTS


def release_buffers() -> None:
    """Free the kept pinned host and device buffers of this process."""
    global _SLOTS
    with _LOCK:
        _SLOTS = []


def run(scene: Scene, method: str, states: np.ndarray, p: np.ndarray, limits: kernels.Limits, switch_tol: np.ndarray,
        float_results: np.ndarray, int_results: np.ndarray, max_batch: int | None = None) -> None:
    """Simulate the rows of ``states`` (m, 4) on the device; results into ``float_results``, ``int_results``.

    The arguments are those of the CPU scene kernels (``kernels.SCENE_KERNELS``), the method by
    name. Batches as :func:`batch_size` says, double-buffered on two streams with pinned host buffers.
    """
    m = states.shape[0]
    if m == 0:
        return
    with _LOCK:
        k = kernel(scene, method)
        if not SIMULATED and not k.overloads:
            _announce(scene, method)
        free = cuda.current_context().get_memory_info()[0]
        batch = batch_size(m, free, max_batch)
        slots = _slots(batch)
        d_p = cuda.to_device(np.ascontiguousarray(p, dtype=np.float64), stream=slots[0].stream)
        d_switch_tol = cuda.to_device(np.ascontiguousarray(switch_tol, dtype=np.float64), stream=slots[0].stream)
        switches = (1 if limits.periodic else 0) | (2 if limits.stiff_slips else 0)  # launch's flag bits
        slots[0].stream.synchronize()  # the parameters are on the device before any launch

        def drain(slot):
            if slot.rows is not None:
                slot.stream.synchronize()
                lo, hi = slot.rows
                float_results[lo:hi] = slot.h_f[: hi - lo]
                int_results[lo:hi] = slot.h_i[: hi - lo]
                slot.rows = None

        try:
            for b, lo in enumerate(range(0, m, batch)):
                hi = min(lo + batch, m)
                n = hi - lo
                slot = slots[b % 2]
                drain(slot)  # its previous batch is back before its buffers are reused
                slot.h_states[:n] = states[lo:hi]
                slot.d_states[:n].copy_to_device(slot.h_states[:n], stream=slot.stream)
                launch = _configure(k, -(-n // THREADS_PER_BLOCK), slot.stream)
                launch(slot.d_states, n, d_p, *limits[:5], switches, d_switch_tol, slot.d_f, slot.d_i)
                slot.d_f[:n].copy_to_host(slot.h_f[:n], stream=slot.stream)
                slot.d_i[:n].copy_to_host(slot.h_i[:n], stream=slot.stream)
                slot.rows = (lo, hi)
        finally:
            for slot in slots:
                drain(slot)
