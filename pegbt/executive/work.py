"""Work off the tick: a leaf hands a heavy computation (perception, planning, compensation) to a worker
thread and picks its result up on a later tick, so the tree keeps ticking while it computes.

Threads, not processes: a job's inputs (a point cloud, a planner holding its OSQP problem) stay shared,
and Open3D, numpy and OSQP release the GIL in their heavy loops (`pegbt bench offload` measures how
much of a job's time the ticking thread still gets). A leaf calls `Leaf.offload(fn, *args)`; a job
must compute from its arguments alone (no blackboard, no transport), since the tree runs on meanwhile.

With a clock whose time stands still while the tree computes (a lockstep simulator, `ManualClock`), the
runner makes the pool `inline`: a job then runs at once, in the tick that asks for it, and the leaf finds
it done on that same tick. Computing costs no simulated time there anyway, and ticks, results and
simulated times stay exactly those of computing in the tick (deterministic campaigns).
"""

from __future__ import annotations

import threading
import time
from collections.abc import Callable
from concurrent.futures import Future, ThreadPoolExecutor
from dataclasses import dataclass
from typing import Any, Generic, TypeVar

T = TypeVar("T")
WORKERS = 2  # two arms may plan at once


class Job(Generic[T]):
    """One computation on a worker: `done` once it finished, `result()` its value (or its exception)."""

    def __init__(
        self, pool: "WorkPool", executor: ThreadPoolExecutor | None, fn: Callable[..., T], args: tuple
    ) -> None:
        """On `executor`'s threads, or at once in the caller when there is none (`WorkPool.inline`)."""
        self._pool = pool
        self.submitted = time.perf_counter()
        self.started: float | None = None
        self.finished: float | None = None
        self.discarded = False
        self._picked = False
        if executor is not None:
            self._future: Future = executor.submit(self._run, fn, args)
            return
        self._future = Future()
        try:
            self._future.set_result(self._run(fn, args))
        except Exception as error:  # delivered by `result()`, as a worker's would be
            self._future.set_exception(error)

    def _run(self, fn: Callable[..., T], args: tuple) -> T:
        self.started = time.perf_counter()
        try:
            return fn(*args)
        finally:
            self.finished = time.perf_counter()

    @property
    def done(self) -> bool:
        return self._future.done()

    def result(self) -> T:
        """The job's value, or the exception it raised; blocks if it is not done. The first call counts the
        time from submission to now as time the tree waited for this job."""
        value = self._future.result()
        if not self._picked:
            self._picked = True
            self._pool.count(self)
        return value

    def discard(self) -> None:
        """Nobody wants the result any more (its leaf was halted): cancel it if it has not started."""
        self.discarded = True
        self._future.cancel()


@dataclass
class WorkStats:
    """Jobs picked up, their compute time and the time from submission to pick-up (wall seconds)."""

    jobs: int = 0
    compute_s: float = 0.0
    waited_s: float = 0.0

    def as_dict(self) -> dict[str, float]:
        return {"jobs": self.jobs, "compute_s": round(self.compute_s, 6), "waited_s": round(self.waited_s, 6)}


class WorkPool:
    """The run's worker threads; `pending()` lists jobs whose results are still wanted and not ready.
    `inline`: run each job at once in the caller (time that stands still while the tree computes)."""

    def __init__(self, workers: int = WORKERS, *, inline: bool = False) -> None:
        self._workers = workers
        self.inline = inline
        self._executor: ThreadPoolExecutor | None = None
        self._jobs: list[Job] = []
        self._lock = threading.Lock()
        self.stats = WorkStats()

    def submit(self, fn: Callable[..., T], *args: Any) -> Job[T]:
        if self._executor is None and not self.inline:
            self._executor = ThreadPoolExecutor(self._workers, thread_name_prefix="pegbt-work")
        job: Job[T] = Job(self, None if self.inline else self._executor, fn, args)
        with self._lock:
            self._jobs = [other for other in self._jobs if not other.done and not other.discarded] + [job]
        return job

    def pending(self) -> list[Job]:
        with self._lock:
            return [job for job in self._jobs if not job.done and not job.discarded]

    def count(self, job: Job) -> None:
        with self._lock:
            self.stats.jobs += 1
            self.stats.waited_s += time.perf_counter() - job.submitted
            if job.started is not None and job.finished is not None:
                self.stats.compute_s += job.finished - job.started

    def close(self) -> None:
        """Drop queued jobs and let running ones end on their own (their results are discarded)."""
        if self._executor is not None:
            self._executor.shutdown(wait=False, cancel_futures=True)
            self._executor = None
        with self._lock:
            for job in self._jobs:
                job.discarded = True
            self._jobs = []
