"""``solver.simulate``: classify rolling initial states by the rules of docs/outcome-engine.md.

Validates the arguments, picks the scene from ``Params`` (docs/outcome-engine.md, Scenes) and
the method's table, flattens the states and hands them to the backend (``solver.engine.backends``): on
the CPU, interleaved chunks (chunk c: states c, c + n, ...) go to the compiled, ``nogil`` scene
kernel on a pool of threads (one per core by default; callers that already run threads (dask)
can pass ``workers=1``); on a CUDA device, to ``solver.engine.cuda_backend`` (one GPU thread per
trajectory).
"""

from __future__ import annotations

import os
from collections.abc import Iterable, Mapping
from concurrent.futures import ThreadPoolExecutor

import numpy as np

from rimroll.solver._arguments import (
    MAX_COUNT,
    MAX_WORKERS,
    SLIP_METHODS,
    finite_array,
    integer,
    positive_number,
    real_array,
    real_number,
    tolerances,
)
from rimroll.solver.engine import backends, compiling, kernels, reduced_simulate, scene_code
from rimroll.solver.engine.outcomes import STEADY_MOTION, on_rim_reason
from rimroll.solver.engine.outputs import OUTPUTS, column
from rimroll.solver.engine.scenes import scene_of
from rimroll.solver.engine.tableaus import TABLEAUS
from rimroll.solver.physics.params import Params
from rimroll.solver.physics.steady_motion import stability
from rimroll.solver.physics.switching import default_tolerances

DEFAULT_MAX_STEPS = 1_000_000
DEFAULT_MAX_SWITCHES = 10_000
_CHUNKS_PER_WORKER = 8  # chunks per thread: balances fast falls against long periodic runs


def simulate(states, params: Params, t_max=20.0, rtol=1e-8, atol=1e-10, method="auto", *,
             max_steps=DEFAULT_MAX_STEPS, max_switches=DEFAULT_MAX_SWITCHES, workers=None, switching=None,
             backend="cpu", terms=()):
    """Run rolling initial states until they fall, roll periodically or reach t_max: integrated, or
    solved exactly in the conservative rolling-only scene (``method``, default "auto").

    Parameters
    ----------
    states : array_like, shape (..., 4)
        Rolling initial states (beta [rad], omega1, omega2, omega3 [1/s]), u1 = u3 = 0: finite
        real numbers (int or float; not bool, complex, strings or None).
    params : Params
        Physical parameters; they pick the scene (mu = inf: rolling only; a term's parameter > 0
        switches it on: k_r, k_d (83), c_r, c_d (Coulomb resistance), rho_air (air drag); with any
        of them the run is dissipative, without periodic detection).
    t_max : float [s]
        End of the run for states that stay on the rim (finite, > 0).
    rtol, atol : float [1], [units of each state component]
        Relative tolerance (1e-14 <= rtol <= 1e-2) and absolute tolerance (0 < atol <= 1, in the
        units of each state component) of the embedded error estimate. rtol also sets what
        counts as a steady motion and as a transversal omega1 zero (``solver.engine.rules``).
    method : {"dp5", "dop853", "reduced", "auto"}
        "auto" (the default, also the studies'): "reduced" where the scene allows it (the conservative
        rolling-only scene, ``backend`` not "cuda"), else "dp5"; "dp5": Dormand-Prince 5(4) with
        4th-order dense output (pass it, or "dop853", to integrate a scene "auto" would solve);
        "dop853": DOP853 with 7th-order dense output; "reduced": the conservative rolling-only scene
        solved exactly on the level of the conserved quantities (60), (68)
        (``solver.engine.reduced_rolling``, docs/explanation/exact-rolling.md; ValueError with one line
        for any other scene; on the CPU; atol, max_steps, max_switches and switching are not used, rtol
        only sets what counts as a transversal omega1 zero). The result's ``attrs["method"]`` says
        which method computed it (``method_used`` says it beforehand).
    max_steps : int
        Budget of attempted steps per trajectory, 1 <= max_steps <= ``MAX_COUNT`` (2**63 - 1)
        (status ``max_steps`` when spent).
    max_switches : int
        Budget of rolling/slipping switches per trajectory, 0 <= max_switches <= ``MAX_COUNT``
        (status ``too_many_switches``).
    workers : int or None
        Threads of the CPU backend, 1 <= workers <= ``MAX_WORKERS`` (1024) (default:
        ``os.cpu_count()``, at most 1024); the compiled kernels release the GIL.
    switching : dict or None
        How slips are run. Overrides of the switching tolerances ``delta``, ``u_stop``,
        ``phi_tol``, ``u_floor``, ``dt_max`` [m/s, m/s, rad, m/s, s] of ``solver.physics.switching``
        (for convergence checks), and ``slip_method``: "rodas4" (default) takes L-stable Rodas4
        steps while the slipping equations are stiff (small slip speed, large mu) and ``method``'s
        steps otherwise (``solver.engine.rosenbrock``); "explicit" takes ``method``'s steps
        throughout, at the stability limit of the stiff slip (for comparisons).
    backend : {"cpu", "cuda", "auto"}
        Where to run (``solver.engine.backends``): the CPU; a CUDA device, one thread per trajectory
        (needs the extra ``rimroll[gpu]`` and a device); or the device when one is usable, else
        the CPU. ``solver.engine.backends.resolve(backend)`` says which one "auto" picks, and on what.
    terms : str or sequence of str
        Load terms of the scene table (``solver.engine.scenes.TERMS``, e.g. one registered with
        ``register_term``) added to the equations of both phases; the terms switched on by a
        parameter (``k_r``, ``k_d``, ``c_r``, ``c_d``, ``rho_air``) come from ``params`` (naming one
        of those with a load runs its kernel at the parameter's value, zero included).

    Returns
    -------
    dict of numpy arrays of shape ``states.shape[:-1]``: ``outcome`` (int8, see
    ``OUTCOME_MEANINGS``), ``t_end`` [s] (0 for ``steady_motion``), ``f2_min`` [N], ``half_period`` [s] (NaN unless
    periodic), ``revolutions`` (signed alpha travelled / 2 pi), ``slip_phases``, ``slip_time``
    [s], ``energy_drift`` (|E(t_end) - E(0)| / max(|E(0)|, m g rho): the integration drift in
    conservative rolling, the energy lost otherwise), ``n_steps`` (attempted steps; with "reduced", the
    solver's function evaluations), ``n_searched`` (accepted steps whose dense output was searched
    for events: the cost of the grazing check, docs/outcome-engine.md), ``n_slip_steps`` (the attempted
    steps of slip phases), ``beta_end``, ``omega1_end``, ``omega2_end``, ``omega3_end`` (the state at t_end, before
    any free flight), ``u1_end``, ``u3_end`` [m/s] (the slip velocity at t_end; 0 when rolling), ``steady_h``
    [1/s^2] (h of (54) for ``steady_motion`` lanes: < 0 stable, > 0 unstable; NaN elsewhere), ``status``
    (int8, see ``STATUS_MEANINGS``; ``stiff_slip`` when the step
    budget ran out mostly in slip phases) and ``on_rim_reason`` (int8,
    ``solver.engine.outcomes.ON_RIM_REASON_MEANINGS``:
    why a run ended on the rim, from outcome, status and slip_phases). A failing lane is recorded in
    ``status`` and never raises.

    Raises
    ------
    ValueError
        For a bad argument, of a wrong type included (a string for a number, a list for
        ``switching``); the message names it, what was given and what is allowed.
    solver.engine.backends.BackendUnavailable
        For ``backend="cuda"`` without the extra or a device (one line saying which).
    """
    x = _checked_states(states, params)
    scene = scene_of(params, _checked_terms(terms))
    switching = _checked_switching(switching)
    slip_method = switching.pop("slip_method", "rodas4")
    if not isinstance(slip_method, str) or slip_method not in SLIP_METHODS:
        raise ValueError(f"switching `slip_method` must be one of {', '.join(map(repr, SLIP_METHODS))}; "
                         f"got {slip_method!r}")
    limits = _checked_limits(t_max, rtol, atol, max_steps, max_switches)._replace(
        periodic=not scene.dissipates(params), stiff_slips=slip_method == "rodas4")
    sw = default_tolerances(**switching)  # checked whichever method runs
    if isinstance(method, str) and method in REDUCED_METHODS:  # exact rolling
        use = _reduced_method(method, params, terms, backend)
        if use == "reduced":
            res = reduced_simulate.solve(x, params, limits.t_max, limits.rtol, _checked_workers(workers))
            return SimulateResult(res, method="reduced")
        return simulate(states, params, t_max, rtol, atol, use, max_steps=max_steps, max_switches=max_switches,
                        workers=workers, switching={**switching, "slip_method": slip_method}, backend=backend,
                        terms=terms)
    if not isinstance(method, str) or method not in TABLEAUS:
        raise ValueError(f"`method` must be one of {sorted(TABLEAUS)} or {', '.join(map(repr, REDUCED_METHODS))}; "
                         f"got {method!r}")
    workers = _checked_workers(workers)
    where = backends.resolve(backend)

    shape = x.shape[:-1]
    flat = np.ascontiguousarray(x.reshape(-1, 4))
    res_f = np.empty((flat.shape[0], kernels.N_RF))
    res_i = np.empty((flat.shape[0], kernels.N_RI), dtype=np.int64)
    if where.name == "cuda":
        from rimroll.solver.engine import cuda_backend

        cuda_backend.run(scene, method, flat, params.as_array(), limits, sw, res_f, res_i)
    else:
        _run_cpu(scene, TABLEAUS[method].method, flat, params.as_array(), sw if scene.slips else None, limits, workers,
                 res_f, res_i)
    return SimulateResult(_fields(flat, shape, res_f, res_i, params), method=method)


REDUCED_METHODS = ("reduced", "auto")
"""The ``method`` values of :func:`simulate` that may run the exact reduced solver."""


class SimulateResult(dict):
    """``simulate``'s result dict with ``attrs`` (``attrs["method"]``: the method that computed it)."""

    def __init__(self, columns, method: str):
        super().__init__(columns)
        self.attrs = {"method": method}


def method_used(method, params: Params, terms=(), backend="cpu") -> str:
    """The method :func:`simulate` runs for ``method`` in the scene of ``params`` and ``terms``: "auto"
    resolved ("reduced" for the conservative rolling-only scene on the CPU, else "dp5"); any other
    value as given (checked by ``simulate``)."""
    if method != "auto":
        return method
    return _reduced_method(method, params, terms, backend)


def _reduced_method(method, params, terms, backend) -> str:
    """"reduced" or "dp5" for ``method`` "reduced" or "auto"; ValueError (one line) when "reduced" is
    asked of a scene it cannot solve, or for a ``backend`` that is not one of ``backends.BACKENDS``."""
    backends.check_name(backend)
    why = reduced_simulate.unsupported(params, () if terms is None else terms)
    if why is None and backend == "cuda":
        why = "the reduced solver runs on the CPU; got backend='cuda'"
    if method == "reduced" and why:
        raise ValueError(f"method='reduced': {why}")
    return "dp5" if why else "reduced"


def _checked_workers(workers) -> int:
    """``workers`` checked (1 to MAX_WORKERS); None: one per core."""
    return integer("workers", min(os.cpu_count() or 1, MAX_WORKERS) if workers is None else workers,
                   maximum=MAX_WORKERS)


def _run_cpu(scene, method, flat, p, sw, limits, workers, res_f, res_i):
    """The states ``flat`` (m, 4) through the scene's compiled kernel on ``workers`` threads; results
    into the rows of res_f, res_i. Chunk c takes the states c, c + n_chunks, ...: costly states sit
    together (a boundary, an island that stays on the rim), and contiguous blocks would hand them
    all to one thread."""
    if flat.shape[0]:  # no state, no kernel call: nothing to compile
        compiling.ensure_compiled(scene, method, (flat, p, sw, method, limits, kernels.new_work(method), res_f, res_i))
    scene_kernel = scene_code.kernel_of(scene)
    m = flat.shape[0]
    n_chunks = min(m, workers * _CHUNKS_PER_WORKER) if workers > 1 else min(m, 1)
    if n_chunks <= 1:
        if m:
            scene_kernel(flat, p, sw, method, limits, kernels.new_work(method), res_f, res_i)
        return
    order = np.argsort(np.arange(m) % n_chunks, kind="stable")
    dealt = flat[order]
    dealt_f = np.empty_like(res_f)
    dealt_i = np.empty_like(res_i)

    def run(lo, hi):
        scene_kernel(dealt[lo:hi], p, sw, method, limits, kernels.new_work(method), dealt_f[lo:hi], dealt_i[lo:hi])

    bounds = np.searchsorted(order % n_chunks, np.arange(n_chunks + 1))
    with ThreadPoolExecutor(max_workers=workers) as pool:
        for fut in [pool.submit(run, lo, hi) for lo, hi in zip(bounds[:-1], bounds[1:])]:
            fut.result()
    res_f[order] = dealt_f
    res_i[order] = dealt_i


def _checked_states(states, params) -> np.ndarray:
    """``states`` as a float array (..., 4) after the checks of :func:`simulate`."""
    if not isinstance(params, Params):
        raise ValueError(f"`params` must be a solver.Params; got {type(params).__name__}")
    x = real_array("states", states)
    if x.ndim < 1 or x.shape[-1] != 4:
        raise ValueError(f"`states` must have last axis 4 (beta, omega1, omega2, omega3); got shape {x.shape}")
    finite_array("states", x)
    return x


def _checked_terms(terms):
    """``terms`` of :func:`simulate` after a check of its type (the names are checked by ``scene_of``)."""
    if terms is None or isinstance(terms, str):
        return terms
    names = tuple(terms) if isinstance(terms, Iterable) and not isinstance(terms, (Mapping, bytes)) else None
    if names is None or not all(isinstance(t, str) for t in names):
        raise ValueError(f"`terms` must be a term's name or a sequence of names (str); got {terms!r}")
    return names


def _checked_switching(switching) -> dict:
    """A copy of ``switching`` of :func:`simulate` after a check of its type and of its values' types
    (their ranges and the names of the tolerances are checked by ``default_tolerances``)."""
    if switching is None:
        return {}
    if not isinstance(switching, Mapping):
        raise ValueError("`switching` must be None or a dict of switching tolerances (solver.physics.switching) "
                         f"and slip_method; got {type(switching).__name__} {switching!r}")
    out = dict(switching)
    for key, value in out.items():
        if key != "slip_method":
            real_number(f"switching[{key!r}]", value, finite=False, allowed="a positive tolerance")
    return out


def _checked_limits(t_max, rtol, atol, max_steps, max_switches) -> kernels.Limits:
    """The :class:`~rimroll.solver.engine.kernels.Limits` of a run after the checks of :func:`simulate`."""
    t_max = positive_number("t_max", t_max)
    rtol, atol = tolerances(rtol, atol)
    return kernels.Limits(t_max, rtol, atol, integer("max_steps", max_steps, maximum=MAX_COUNT),
                          integer("max_switches", max_switches, minimum=0, maximum=MAX_COUNT), True)


def _fields(flat, shape, res_f, res_i, params):
    """The result dict of :func:`simulate` (``solver.engine.outputs``) from the result rows of the kernels."""
    out = {}
    for item in OUTPUTS:
        if item.in_kernel:
            rows = res_f if item.dtype == "float64" else res_i
            out[item.name] = rows[:, column(item.name)].astype(item.dtype).reshape(shape)
    out["steady_h"] = _steady_h(flat, out["outcome"].reshape(-1), params).reshape(shape)
    out["on_rim_reason"] = on_rim_reason(out["outcome"], out["status"], out["slip_phases"])
    return out


def _steady_h(flat, outcome, params):
    """h of (54) [1/s^2] for the lanes on a steady motion (NaN elsewhere): < 0 stable, > 0 unstable."""
    h = np.full(flat.shape[0], np.nan)
    on = outcome == STEADY_MOTION
    if on.any():
        h[on] = stability(flat[on, 0], flat[on, 3], params)
    return h
