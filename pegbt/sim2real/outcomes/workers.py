"""Where simulated transfers run: a batch of tasks cut into jobs, simulated in local worker processes or on
a Dask cluster, and handed back as each job is done.

Kept apart from `simulate`, the entry the workers run (`run_job`), so that how a batch is spread over
workers is not part of what a simulated transfer is (`bench.outcomes_records.simulator_identity`): a change
here leaves the transfers a benchmark kept valid.
"""

from __future__ import annotations

import math
from collections.abc import Iterable, Iterator, Sequence
from concurrent.futures import Executor, ProcessPoolExecutor, as_completed
from dataclasses import dataclass
from functools import partial
from typing import TYPE_CHECKING, Protocol, runtime_checkable

from pegbt.sim2real.outcomes.phasesim import TransferResult
from pegbt.sim2real.outcomes.simulate import WITH_RECOVERY, Mapper, Task, in_trials, run_job
from pegbt.sim2real.outcomes.trialsim import trial_of

if TYPE_CHECKING:
    from pegbt.evaluation.cluster import ClusterTls


@runtime_checkable
class PartedMapper(Mapper, Protocol):
    """A mapper that also hands back each job of a batch as it is done (`Part`), so a caller keeps what
    a long batch has simulated so far (`bench.outcomes_records.StoredMemo`)."""

    def parts(self, tasks: Sequence[Task]) -> Iterator[Part]: ...


SPREAD = 3  # jobs per worker a batch is cut into at least, so the workers finish together
LARGEST_JOB = 600  # transfers played times worlds (about 2 minutes of a core): a killed run loses no more


@dataclass(frozen=True)
class Job:
    """Tasks (by index) simulated together in the worlds `worlds` (a slice of their worlds): a trial's
    seeds, or one task. `size`: what it costs, transfers played times worlds."""

    tasks: tuple[int, ...]
    worlds: slice
    size: int


Part = tuple[Job, list[list[TransferResult]]]  # a job and its results: per task, per world of its part


def cut_into_jobs(tasks: Sequence[Task], attempts: int, workers: int = 1) -> list[Job]:
    """The tasks grouped so that a trial's seeds with the same worlds are one job, simulated once in order;
    every other task is a job of its own. A job larger than `LARGEST_JOB`, or with several `workers` than a
    `SPREAD`-th of a worker's share, is cut into consecutive parts of its worlds: one unilateral cell of 16
    seeds is a trial of 12 transfers and one of 4, which two workers would share 12 to 4, and 5 seeds of one
    trial would keep one worker alone. Each part replays the arm's motion anew (`bench.Replay`), at about
    one more world's cost (a 12-transfer unilateral trial: 1.0 s of CPU a part, 1.1 s a world), so a part of
    `LARGEST_JOB` spends a few per cent on it; results do not depend on the cut. The largest jobs come
    first."""
    groups: dict[object, list[int]] = {}
    for i, (worlds, variant, condition, seed) in enumerate(tasks):
        trial = (worlds, variant, condition, trial_of(variant, seed)[0])
        groups.setdefault(trial if in_trials(attempts, variant) else i, []).append(i)

    def played(group: list[int]) -> int:
        variant = tasks[group[0]][1]
        if not in_trials(attempts, variant):
            return 1
        return max(trial_of(variant, tasks[i][3])[1] for i in group) + 1

    sized = [(group, played(group), len(tasks[group[0]][0])) for group in groups.values()]
    share = sum(n * w for _, n, w in sized) / (SPREAD * workers) if workers > 1 else math.inf
    target = min(share, LARGEST_JOB)
    jobs = []
    for group, n, count in sized:
        parts = min(count, max(1, math.ceil(n * count / target)))
        edges = [round(k * count / parts) for k in range(parts + 1)]
        jobs += [Job(tuple(group), slice(lo, hi), n * (hi - lo)) for lo, hi in zip(edges, edges[1:])]
    return sorted(jobs, key=lambda job: job.size, reverse=True)


def job_tasks(tasks: Sequence[Task], job: Job) -> list[Task]:
    """The tasks of `job`, each with the job's part of its worlds."""
    return [(tasks[i][0][job.worlds], *tasks[i][1:]) for i in job.tasks]


def gathered(tasks: Sequence[Task], done: Iterable[Part]) -> list[list[TransferResult]]:
    """The jobs' results, in whatever order they were done, back in the order of `tasks`, each task's
    worlds in their order."""
    parts: list[dict[int, list[TransferResult]]] = [{} for _ in tasks]
    for job, outcome in done:
        for i, result in zip(job.tasks, outcome):
            parts[i][job.worlds.start] = result
    return [[r for _, part in sorted(found.items()) for r in part] for found in parts]


class LocalMapper:
    """Simulated transfers in `workers` local processes (in this process when `workers` is 0), each with up
    to `attempts` picks, the arms `registered` as the paper's were or not."""

    def __init__(self, workers: int, attempts: int = WITH_RECOVERY, registered: bool = False) -> None:
        self._pool: Executor | None = ProcessPoolExecutor(workers) if workers > 0 else None
        self._workers = workers
        self._attempts = attempts
        self._run = partial(run_job, attempts=attempts, registered=registered)

    def __call__(self, tasks: Sequence[Task]) -> list[list[TransferResult]]:
        return gathered(tasks, self.parts(tasks))

    def parts(self, tasks: Sequence[Task]) -> Iterator[Part]:
        """Each job of `tasks` with its results, as the workers finish them."""
        jobs = cut_into_jobs(tasks, self._attempts, self._workers)
        if self._pool is None:
            for job in jobs:
                yield job, self._run(job_tasks(tasks, job))
            return
        futures = {self._pool.submit(self._run, job_tasks(tasks, job)): job for job in jobs}
        try:
            for future in as_completed(futures):
                yield futures[future], future.result()
        finally:
            for future in futures:
                future.cancel()

    def close(self) -> None:
        if self._pool is not None:
            self._pool.shutdown()


class ClusterMapper:
    """Simulated transfers as tasks on a Dask scheduler (`pegbt eval --cluster`'s `connect`, with its
    certificates `tls` for a `tls://` address; its workers checked as eval's are: present, and on this
    commit), each with up to `attempts` picks, the arms `registered` as the paper's were or not."""

    def __init__(
        self,
        address: str,
        attempts: int = WITH_RECOVERY,
        registered: bool = False,
        tls: ClusterTls | None = None,
    ) -> None:
        from pegbt.evaluation.cluster import check_workers, connect

        self._client = connect(address, tls)
        try:  # a worker on other code would simulate another simulator's transfers, kept as this one's
            self._workers = check_workers(self._client, one_per_worker=False)
        except BaseException:
            self._client.close()
            raise
        self._attempts = attempts
        self._run = partial(run_job, attempts=attempts, registered=registered)

    def __call__(self, tasks: Sequence[Task]) -> list[list[TransferResult]]:
        return gathered(tasks, self.parts(tasks))

    def parts(self, tasks: Sequence[Task]) -> Iterator[Part]:
        """Each job of `tasks` with its results, as the cluster's workers finish them; every job is
        submitted at once, so a batch keeps as many workers busy as it has jobs."""
        from distributed import as_completed as as_done

        jobs = cut_into_jobs(tasks, self._attempts, self._workers)
        futures = self._client.map(self._run, [job_tasks(tasks, job) for job in jobs], pure=False)
        job_of = {future.key: job for future, job in zip(futures, jobs)}
        try:
            for future, outcome in as_done(futures, loop=self._client.loop, with_results=True):
                yield job_of[future.key], outcome
        finally:
            self._client.cancel(futures)

    def close(self) -> None:
        self._client.close()
