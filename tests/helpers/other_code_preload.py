"""A dask worker preload (``dask worker --preload tests/helpers/other_code_preload.py``): the worker runs as if
its rimroll were another checkout's, its code digest (``study.plan.code_digest``) differing from the
client's. Used by tests/study/test_cluster.py to check that such a worker refuses every chunk."""

from rimroll.study import plan

if not hasattr(plan, "real_code_digest"):  # dask may run a preload file twice in one namespace
    plan.real_code_digest = plan.code_digest


def _other(study):
    return plan.real_code_digest(study)[::-1]  # another 64-hex digest


plan.code_digest = _other
