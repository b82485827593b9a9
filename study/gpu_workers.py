"""One GPU per dask worker for runs on the CUDA backend (``study.fanout``).

:class:`OneGPUPerWorker` is registered on the run's client: the worker named i (an integer, as
a LocalCluster names its workers) computes on CUDA device i modulo the devices it sees, through
``solver.engine.backends.DEVICE_ENV``; a worker with another name keeps device 0, which is the one
device it sees when it was started with ``CUDA_VISIBLE_DEVICES`` set (as dask-cuda starts them).
Its own module, so that worker processes unpickle it by reference.
"""

from __future__ import annotations

import os

from distributed.diagnostics.plugin import WorkerPlugin


class OneGPUPerWorker(WorkerPlugin):
    name = "rimroll-one-gpu-per-worker"

    def setup(self, worker):
        from rimroll.solver.engine.backends import DEVICE_ENV

        try:
            index = int(worker.name)
        except (TypeError, ValueError):
            return
        os.environ[DEVICE_ENV] = str(index)
