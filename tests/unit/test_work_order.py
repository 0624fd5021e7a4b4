"""The order of work off the tick: on two shared cores two jobs at once each take about twice as long, so
work done ahead of need gives way to the jobs the tree was waiting for when it was asked for
(`WorkPool.give_way`), until a leaf wants it; not to jobs asked for after it."""

from __future__ import annotations

import threading
import time
from collections.abc import Callable

from pegbt.executive.work import WorkPool

BOUND = 5.0  # s: every wait in these tests is bounded


def _wait_for(test: Callable[[], bool], what: str) -> None:
    deadline = time.monotonic() + BOUND
    while not test():
        assert time.monotonic() < deadline, what
        time.sleep(0.001)


def test_a_job_submitted_ahead_waits_until_no_wanted_job_computes() -> None:
    pool = WorkPool()
    release = threading.Event()
    order: list[str] = []

    def plan() -> None:
        release.wait(BOUND)
        order.append("wanted")

    wanted = pool.submit(plan)
    ahead = pool.submit_ahead(lambda: order.append("ahead"))
    try:
        time.sleep(0.05)
        assert ahead.started is None and not ahead.done  # it has not begun beside the wanted job
        release.set()
        _wait_for(lambda: ahead.done, "the job ahead never ran")
        assert order == ["wanted", "ahead"]
        assert wanted.done
    finally:
        release.set()
        pool.close()


def test_a_job_ahead_that_a_leaf_comes_to_want_runs_at_once() -> None:
    pool = WorkPool()
    release = threading.Event()
    pool.submit(release.wait, BOUND)
    ahead = pool.submit_ahead(lambda: "plan")
    try:
        time.sleep(0.02)
        assert not ahead.done
        ahead.wanted()
        _wait_for(lambda: ahead.done, "a wanted job ahead still gave way")
        assert ahead.result() == "plan"
    finally:
        release.set()
        pool.close()


def test_a_job_ahead_does_not_wait_for_jobs_discarded_before_they_began_nor_after_close() -> None:
    pool = WorkPool(workers=1)
    release = threading.Event()
    pool.submit(release.wait, BOUND)
    queued = pool.submit(lambda: None)  # behind the first on the one worker
    queued.discard()
    ahead = pool.submit_ahead(lambda: "plan")
    try:
        time.sleep(0.02)
        assert not ahead.done  # the first still computes
        release.set()
        _wait_for(lambda: ahead.done, "the job ahead waited for a cancelled job")
        blocker = threading.Event()
        pool.submit(blocker.wait, BOUND)
        late = pool.submit_ahead(lambda: "late")
        pool.close()
        _wait_for(lambda: late.done, "closing the pool left a job ahead waiting")
        blocker.set()
    finally:
        release.set()
        pool.close()


def test_a_job_ahead_does_not_wait_for_wanted_jobs_asked_for_after_it() -> None:
    pool = WorkPool()
    first, later = threading.Event(), threading.Event()
    pool.submit(first.wait, BOUND)
    ahead = pool.submit_ahead(lambda: "carry")  # a plan ahead, soon on a handover's critical path
    asked_later = pool.submit(later.wait, BOUND)
    try:
        time.sleep(0.02)
        assert not ahead.done  # the job asked for before it still computes
        first.set()
        _wait_for(lambda: ahead.done, "the job ahead waited for a job asked for after it")
        assert not asked_later.done
    finally:
        first.set()
        later.set()
        pool.close()
