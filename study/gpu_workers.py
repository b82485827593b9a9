"""One GPU per dask worker for runs on the CUDA backend (``study.fanout``).

:class:`OneGPUPerWorker` is registered on the run's client and picks, on each worker, the CUDA
device it computes on (``solver.engine.backends.DEVICE_ENV``, an index into the devices the worker
sees):

* the workers of rimroll's own local cluster (``local=True``: one per device, named 0, 1, ...) all
  see the devices of the process that started them: the worker named i takes device i;
* a worker of another cluster whose environment has ``CUDA_VISIBLE_DEVICES`` takes device 0 of
  its visible devices: the cluster chose them for it (dask-cuda's ``LocalCUDACluster`` and
  ``dask cuda worker`` give worker i the list rotated to start at its own GPU, ``0,1,2,3`` then
  ``1,2,3,0``...; a batch system gives each task its own GPUs);
* any other worker: by its name if that is an integer (modulo the devices it sees), else device 0.

Its own module, so that worker processes unpickle it by reference.
"""

from __future__ import annotations

import os

from distributed.diagnostics.plugin import WorkerPlugin

VISIBLE = "CUDA_VISIBLE_DEVICES"


def device_index(name, local: bool, environ=None, count=None) -> int:
    """The index of the device a worker computes on (see the module docstring). ``name``: the worker's
    name; ``environ``: its environment (default ``os.environ``); ``count``: the number of devices it
    sees (default: asked from the driver, only when needed; 0 when unknown)."""
    environ = os.environ if environ is None else environ
    if not local and environ.get(VISIBLE, "").strip():
        return 0
    try:
        index = int(name)
    except (TypeError, ValueError):
        return 0
    if local:
        return index
    if count is None:
        count = _device_count()
    return index % count if count else index


def _device_count() -> int:
    from rimroll.solver.engine.backends import cuda_device_count

    try:
        return int(cuda_device_count())
    except Exception:  # noqa: BLE001  no driver: the index stands as it is, and the backend reports the rest
        return 0


class OneGPUPerWorker(WorkerPlugin):
    name = "rimroll-one-gpu-per-worker"

    def __init__(self, local: bool = False):
        self.local = local

    def setup(self, worker):
        from rimroll.solver.engine.backends import DEVICE_ENV

        os.environ[DEVICE_ENV] = str(device_index(worker.name, self.local))
