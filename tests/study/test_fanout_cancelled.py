"""A chunk whose future or whose fetch is cancelled in a run (``study.fanout.Fetches``): computed or fetched
again, or, when that keeps happening, one UserError naming the chunk with the count of chunks saved, which
stay on disk; never distributed's ``UnboundLocalError`` (dask/distributed#8514) nor a traceback.

The runs call ``fanout.run`` on a local cluster of threads through a client whose submissions a test
cancels or whose gathers it breaks on purpose, with the test-only ``fanout-probe`` study
(tests/helpers/fanout_probe.py); each part is compared with ``compute_chunk`` called directly.
"""

from __future__ import annotations

import asyncio

import numpy as np
import pytest

from rimroll.study import fanout
from rimroll.study.parts import PartStore
from rimroll.study.plan import compute_chunk, make_plan
from rimroll.study.progress import ProgressLine
from rimroll.study.registry import UserError


class _Meddling:
    """Client ``c`` as ``fanout.run`` sees it, but ``meddle(c, k, future)`` is called on each chunk ``k``
    it submits, right after the submission."""

    def __init__(self, c, meddle):
        self._c, self._meddle = c, meddle
        self.submitted = []

    def __getattr__(self, name):
        return getattr(self._c, name)

    def submit(self, *args, key, **kw):
        future = self._c.submit(*args, key=key, **kw)
        k = int(key.split("-")[2])  # chunk-FINGERPRINT-K-TOKEN[-ATTEMPT]
        self.submitted.append(k)
        self._meddle(self._c, k, future)
        return future


def _run(probe, out, meddle):
    """``fanout.run`` of every chunk of the probe into ``out`` on one worker thread, ``meddle`` applied:
    (its stats or the UserError it raised, the store, the plan, the chunks submitted in order)."""
    plan = make_plan(probe)
    store = PartStore(out, probe.name, plan.fingerprint)
    with fanout.client(workers=1) as c:
        meddling = _Meddling(c, meddle)
        try:
            result = fanout.run(plan, store, list(range(plan.n_chunks)), meddling,
                                ProgressLine(plan.n_chunks, probe.name, enabled=False), timeout=30)
        except UserError as exc:
            result = exc
    return result, store, plan, meddling.submitted


def _saved_parts_are_right(store, plan) -> int:
    """Every part on disk holds what ``compute_chunk`` computes for its chunk; their number."""
    saved = 0
    for k in range(plan.n_chunks):
        arrays = store.load(k, plan.expected(k))
        if arrays is None:
            continue
        saved += 1
        for name, values in compute_chunk(plan.job(k)).items():
            np.testing.assert_array_equal(arrays[name], values, err_msg=f"chunk {k} {name}")
    return saved


def test_a_chunk_cancelled_once_is_computed_again_under_a_new_key(probe, tmp_path):
    def cancel_chunk_3_once(c, k, future):
        if k == 3 and not getattr(cancel_chunk_3_once, "done", False):
            cancel_chunk_3_once.done = True
            future.cancel()

    stats, store, plan, submitted = _run(probe, tmp_path, cancel_chunk_3_once)
    assert not isinstance(stats, Exception), stats
    assert stats.computed == plan.n_chunks and submitted.count(3) == 2
    assert _saved_parts_are_right(store, plan) == plan.n_chunks


def test_a_chunk_cancelled_every_time_is_one_line_and_the_saved_chunks_stay(probe, tmp_path):
    def cancel_chunk_5(c, k, future):
        if k == 5:
            future.cancel()

    error, store, plan, submitted = _run(probe, tmp_path, cancel_chunk_5)
    assert isinstance(error, UserError), error
    message = str(error)
    saved = _saved_parts_are_right(store, plan)
    assert submitted.count(5) == fanout.Fetches.RETRIES + 1 and 0 < saved < plan.n_chunks
    assert "\n" not in message and f"chunk 5 was cancelled {fanout.Fetches.RETRIES + 1} times" in message
    assert f"{saved} of {plan.n_chunks} chunks saved" in message and "rerun the same command" in message


def _break_gathers(c):
    """Leave client ``c`` as distributed 2026.8 leaves a client whose pending gather was cancelled before it
    started (dask/distributed#8514): ``c._gather_future`` a cancelled asyncio future, which every later gather
    of the client awaits, and ``c._gather_keys`` the keys that gather was to fetch."""

    async def cancelled_gather():
        broken = asyncio.get_running_loop().create_future()
        broken.cancel()
        c._gather_future, c._gather_keys = broken, set()

    c.sync(cancelled_gather)


def test_a_client_whose_gathers_are_cancelled_stops_in_one_line_not_unbound_local_error(probe, tmp_path):
    """The state behind the flaky UnboundLocalError: ``Future.result`` raises it there (the assumption
    checked first); a run on such a client retries each fetch, then stops with one UserError, every chunk
    it saved before intact on disk."""
    with fanout.client(workers=1) as c:
        future = c.submit(sum, [1, 2], pure=False)
        assert future.result(timeout=30) == 3
        _break_gathers(c)
        with pytest.raises((UnboundLocalError, asyncio.CancelledError)):
            c.submit(sum, [3, 4], pure=False).result(timeout=30)

    def break_at_chunk_6(c, k, future):
        if k == 6 and not getattr(break_at_chunk_6, "done", False):
            break_at_chunk_6.done = True
            future.result(timeout=30)  # chunks before it and in the window may still finish and be fetched
            _break_gathers(c)

    error, store, plan, _ = _run(probe, tmp_path, break_at_chunk_6)
    assert isinstance(error, UserError), error
    message = str(error)
    saved = _saved_parts_are_right(store, plan)
    assert "\n" not in message and f"was cancelled {fanout.Fetches.RETRIES + 1} times" in message
    assert f"{saved} of {plan.n_chunks} chunks saved" in message and saved < plan.n_chunks


def test_a_run_polling_far_faster_than_its_chunks_end_fetches_every_chunk(probe, tmp_path, monkeypatch):
    """The run's thread waits on its fetches with a bound of POLL; at 1 ms (a 2-core machine under load:
    the bound passes before the event loop runs) no fetch is cancelled, and every part is right. A bounded
    ``Future.result(timeout=POLL)`` at that rate left the client's gathers cancelled within a second."""
    monkeypatch.setattr(fanout, "POLL", 0.001)
    stats, store, plan, submitted = _run(probe, tmp_path, lambda c, k, future: None)
    assert not isinstance(stats, Exception), stats
    assert stats.computed == plan.n_chunks and sorted(submitted) == list(range(plan.n_chunks))
    assert _saved_parts_are_right(store, plan) == plan.n_chunks
