"""Work off the tick: a leaf hands a heavy computation (perception, planning, compensation) to a worker
thread and picks its result up on a later tick, so the tree keeps ticking while it computes.

Threads, not processes: a job's inputs (a point cloud, a planner holding its OSQP problem) stay shared,
and Open3D, numpy and OSQP release the GIL in their heavy loops (`pegbt bench offload` measures how
much of a job's time the ticking thread still gets). A leaf calls `Leaf.offload(fn, *args)`; a job
must compute from its arguments alone (no blackboard, no transport), since the tree runs on meanwhile.

Work done ahead of need (`submit_ahead`: a motion planned while the one before it plays) runs on a thread
of its own, so that it never queues a job the tree waits for now behind it; and it starts only once the
jobs the tree was waiting for when it was submitted have ended (or once a leaf comes to want it). On two
cores shared with the robot, and with pure-Python pre-compensation holding the GIL, two jobs at once each
take about twice as long (two transfers' planning and pre-compensation, load 13: done after 200 and 253
ms at once, 102 and 218 ms one after the other): a bilateral arm's first approach after a look waited for
the other arm's carry, planned ahead as soon as that arm's approach was sent, as long as for its own plan.
Only those it finds: a handover's plans ahead are on its critical path, and made to wait for every job
asked for later too (or run with the tree's jobs one at a time) its transfers took longer.

The run's ticking sleeps between ticks through `WorkPool.wait`, which a job ending cuts short: its leaf
gets the result on the next tick at once, not up to a period later; so does a test the runner gives it
(`until`: a running leaf's motion reported done), checked every `poll` seconds.

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
from dataclasses import dataclass, field
from typing import Any, Generic, TypeVar

from pegbt.clock import Clock

T = TypeVar("T")
WORKERS = 2  # two arms may plan at once


class Job(Generic[T]):
    """One computation on a worker: `done` once it finished, `result()` its value (or its exception)."""

    def __init__(
        self,
        pool: WorkPool,
        executor: ThreadPoolExecutor | None,
        fn: Callable[..., T],
        args: tuple,
        *,
        ahead: bool = False,
        behind: list[Job] | None = None,
    ) -> None:
        """On `executor`'s threads, or at once in the caller when there is none (`WorkPool.inline`);
        `ahead`: nobody wants it yet, so it gives way to the jobs `behind` (`WorkPool.give_way`)."""
        self._pool = pool
        self.ahead = ahead  # not wanted yet
        self.behind = [job for job in behind or [] if not job.ahead]  # wanted jobs computing before it
        self.kind = getattr(fn, "func", fn).__qualname__  # what computes (a partial's function)
        self.submitted = self.wanted_from = time.perf_counter()
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
        if self.ahead:
            self._pool.give_way(self)
        self.started = time.perf_counter()
        try:
            return fn(*args)
        finally:
            self.finished = time.perf_counter()
            self._pool.ended()

    @property
    def done(self) -> bool:
        return self._future.done()

    @property
    def computing(self) -> bool:
        """Running or queued to run (a job that ended, or was cancelled before it began, is not)."""
        return self.finished is None and not self._future.done()

    def result(self) -> T:
        """The job's value, or the exception it raised; blocks if it is not done. The first call counts the
        time from submission (or from when a leaf came to want it, `wanted`) to now as time the tree
        waited for this job."""
        value = self._future.result()
        if not self._picked:
            self._picked = True
            self._pool.count(self)
        return value

    def outcome(self) -> T:
        """The job's value, or the exception it raised, for work that builds on it ahead of need (blocks
        until it is done); unlike `result()`, counts no wait: no leaf waited for it."""
        return self._future.result()

    def wanted(self) -> None:
        """A leaf wants the result from now: a job submitted ahead of need counts the wait from here."""
        self.wanted_from = time.perf_counter()
        self.ahead = False
        self._pool.changed()

    def discard(self) -> None:
        """Nobody wants the result any more (its leaf was halted): cancel it if it has not started."""
        self.discarded = True
        self._future.cancel()
        self._pool.changed()


@dataclass
class WorkStats:
    """Jobs picked up, their compute time and the time from submission to pick-up (wall seconds), in all
    and by the function each job ran (`by_kind`: name → [jobs, compute_s, waited_s])."""

    jobs: int = 0
    compute_s: float = 0.0
    waited_s: float = 0.0
    by_kind: dict[str, list[float]] = field(default_factory=dict)

    def add(self, kind: str, compute: float, waited: float) -> None:
        self.jobs += 1
        self.compute_s += compute
        self.waited_s += waited
        figures = self.by_kind.setdefault(kind, [0, 0.0, 0.0])
        figures[0] += 1
        figures[1] += compute
        figures[2] += waited

    def as_dict(self) -> dict[str, Any]:
        return {
            "jobs": self.jobs,
            "compute_s": round(self.compute_s, 6),
            "waited_s": round(self.waited_s, 6),
            "by_kind": {
                kind: {"jobs": int(jobs), "compute_s": round(compute, 6), "waited_s": round(waited, 6)}
                for kind, (jobs, compute, waited) in sorted(self.by_kind.items())
            },
        }


class WorkPool:
    """The run's worker threads; `pending()` lists jobs whose results are still wanted and not ready.
    `inline`: run each job at once in the caller (time that stands still while the tree computes)."""

    def __init__(self, workers: int = WORKERS, *, inline: bool = False) -> None:
        self._workers = workers
        self.inline = inline
        self._executor: ThreadPoolExecutor | None = None
        self._ahead: ThreadPoolExecutor | None = None
        self._jobs: list[Job] = []
        self._lock = threading.Lock()
        self._turn = threading.Condition(self._lock)  # a wanted job ended or an ahead job became wanted
        self._closed = False
        self.stats = WorkStats()
        self._ended = threading.Event()
        self._ends = self._ends_seen = 0  # jobs ended, and how many had when `wait` last returned

    def ended(self) -> None:
        """A job has ended (called on its worker thread)."""
        with self._lock:
            self._ends += 1
            self._ended.set()
            self._turn.notify_all()

    def changed(self) -> None:
        """A job became wanted or was discarded: an ahead job waiting for its turn looks again."""
        with self._lock:
            self._turn.notify_all()

    def give_way(self, job: Job) -> None:
        """On the ahead thread, before `job` (submitted ahead) computes: wait until the wanted jobs it was
        submitted behind (`Job.behind`) have ended, unless a leaf comes to want `job` meanwhile. A wanted
        job always ends, so this wait does too."""
        with self._turn:
            self._turn.wait_for(
                lambda: self._closed or not job.ahead or not any(other.computing for other in job.behind)
            )

    def wait(
        self, clock: Clock, seconds: float, until: Callable[[], bool] | None = None, poll: float = 0.002
    ) -> None:
        """Wait `seconds` on `clock`, or less if a job ends meanwhile or has ended since the last wait (the
        tick before may have looked too early), or `until()` turns true (checked every `poll` s), so that
        the tree goes on at once instead of up to a period later. The run's ticking sleeps through this."""
        if self.inline:
            clock.wait(seconds)
            return
        with self._lock:
            ended_since = self._ends != self._ends_seen
            self._ended.clear()
        if not ended_since:
            if until is not None and not until():  # one already true: the tick just made saw it, went on
                self._poll(clock, seconds, until, poll)
            elif self.pending():
                end = clock.now() + seconds
                if not self._ended.wait(seconds):
                    clock.wait(max(0.0, end - clock.now()))
            else:
                clock.wait(seconds)
        with self._lock:
            self._ends_seen = self._ends

    def _poll(self, clock: Clock, seconds: float, until: Callable[[], bool], poll: float) -> None:
        """Wait up to `seconds` on `clock`, in slices of `poll`, until a job ends or `until()` is true."""
        deadline = clock.now() + seconds
        while (left := deadline - clock.now()) > 0:
            if self._ended.wait(min(poll, left)) or until():
                return

    def submit(self, fn: Callable[..., T], *args: Any) -> Job[T]:
        if self._executor is None and not self.inline:
            self._executor = ThreadPoolExecutor(self._workers, thread_name_prefix="pegbt-work")
        return self._add(Job(self, None if self.inline else self._executor, fn, args))

    def submit_ahead(self, fn: Callable[..., T], *args: Any) -> Job[T]:
        """As `submit`, for work nobody waits for yet: on its own thread, behind no job wanted now."""
        if self._ahead is None and not self.inline:
            self._ahead = ThreadPoolExecutor(1, thread_name_prefix="pegbt-ahead")
        if self.inline:
            return self._add(Job(self, None, fn, args))
        return self._add(Job(self, self._ahead, fn, args, ahead=True, behind=self.pending()))

    def _add(self, job: Job[T]) -> Job[T]:
        with self._lock:
            self._jobs = [other for other in self._jobs if not other.done and not other.discarded] + [job]
        return job

    def pending(self) -> list[Job]:
        with self._lock:
            return [job for job in self._jobs if not job.done and not job.discarded]

    def count(self, job: Job) -> None:
        computed = 0.0 if job.started is None or job.finished is None else job.finished - job.started
        with self._lock:
            self.stats.add(job.kind, computed, time.perf_counter() - job.wanted_from)

    def close(self) -> None:
        """Drop queued jobs and let running ones end on their own (their results are discarded)."""
        for executor in (self._executor, self._ahead):
            if executor is not None:
                executor.shutdown(wait=False, cancel_futures=True)
        self._executor = self._ahead = None
        with self._lock:
            self._closed = True
            self._turn.notify_all()
            for job in self._jobs:
                job.discarded = True
            self._jobs = []
