"""Many simulated transfers per cell, in local worker processes (or on a Dask cluster), summed into counts.

Seeds are shared across the worlds compared (common random numbers): the same layouts and the same
perception noise for every parameter value, so differences between worlds are the effects', not luck's.
A task is one transfer (variant, condition, seed) in every world at once, so one process simulates the
arm's motion once and replays it in the worlds where it is the same (`bench.Replay`). Under pegbt's
trees a unilateral transfer is simulated within its trial, in order (`trialsim`): the seeds of
one trial in the same worlds are one job, the trial simulated once for them all.

How many attempts a transfer gets is the real protocol's, not a fitted knob (`attempts_for`): pegbt's trees
regrasp a dropped block; the reference paper's robot moved each block once and skipped a transfer whose
block was no longer on its peg, which is why its attempts end at a block lost for good. Under that
protocol a way back whose block was never placed is not an attempt at all (the paper's 75, 68 and 79
attempts of 120), nor, in bilateral, one whose action pair's other block was not (`paperpairs`): it is
counted apart (`SimCounts.skipped`), not as a failure at `sense`. Under that
protocol each arm is also registered to the camera as the paper's were, with itself (`registered_for`).
"""

from __future__ import annotations

import math
from collections.abc import Iterable, Iterator, Sequence
from concurrent.futures import Executor, ProcessPoolExecutor, as_completed
from dataclasses import dataclass, field, replace
from functools import partial
from typing import TYPE_CHECKING, Protocol, runtime_checkable

import numpy as np

from pegbt.errors import PegbtError
from pegbt.sim.world_effects import WorldEffects
from pegbt.sim2real.outcomes.cells import PHASES, Outcomes
from pegbt.sim2real.outcomes.phasesim import REGRASPS, Replay, TransferResult, simulate_transfer
from pegbt.sim2real.outcomes.trialsim import in_order, simulate_trial, trial_of

if TYPE_CHECKING:
    from pegbt.evaluation.cluster import ClusterTls

CATEGORIES = ("placed", *PHASES)  # a transfer placed, or failed for good in this phase (its first failure)
Key = tuple[str, str]


@dataclass
class SimCounts:
    """Simulated transfers of one cell in one world: per category, and their mean seconds (of all, which
    end where a failure stops the arm, and of those placed, which went through every phase: what a real
    table's mean transfer time compares with)."""

    counts: dict[str, int] = field(default_factory=lambda: dict.fromkeys(CATEGORIES, 0))
    seconds: float = 0.0
    placed_seconds: float = 0.0
    skipped: int = 0  # transfers the protocol never attempted (their block was lost on the way out)

    @property
    def attempted(self) -> int:
        return sum(self.counts.values())

    @property
    def succeeded(self) -> int:
        return self.counts["placed"]

    @property
    def rate(self) -> float:
        return self.succeeded / self.attempted if self.attempted else float("nan")

    def vector(self) -> np.ndarray:
        return np.array([self.counts[c] for c in CATEGORIES], dtype=float)

    def merge(self, other: SimCounts) -> None:
        """`other`'s transfers (of the same cell and world, other seeds) added to these."""
        n, m = self.attempted, other.attempted
        k, j = self.succeeded, other.succeeded
        for category, count in other.counts.items():
            self.counts[category] += count
        self.skipped += other.skipped
        self.seconds = (self.seconds * n + other.seconds * m) / (n + m) if n + m else 0.0
        self.placed_seconds = (self.placed_seconds * k + other.placed_seconds * j) / (k + j) if k + j else 0.0

    @property
    def mean_transfer_s(self) -> float | None:
        """The mean seconds of the transfers placed, if any were."""
        return self.placed_seconds if self.succeeded else None

    def add(self, result: TransferResult) -> None:
        category = category_of(result)
        if category is None:
            self.skipped += 1
            return
        n, k = self.attempted, self.succeeded
        self.counts[category] += 1
        self.seconds = (self.seconds * n + result.seconds) / (n + 1)
        if result.succeeded:
            self.placed_seconds = (self.placed_seconds * k + result.seconds) / (k + 1)


def category_of(result: TransferResult) -> str | None:
    """The `CATEGORIES` entry a transfer counts in: placed, or the phase of its first failure for good;
    None for a transfer the protocol never attempted."""
    if result.skipped:
        return None
    return "placed" if result.succeeded else (result.phase or "grasp")


Task = tuple[tuple[WorldEffects, ...], str, str, int]  # worlds, variant, condition, seed


class Mapper(Protocol):
    def __call__(self, tasks: Sequence[Task]) -> list[list[TransferResult]]: ...


@runtime_checkable
class PartedMapper(Mapper, Protocol):
    """A mapper that also hands back each job of a batch as it is done (`Part`), so a caller keeps what
    a long batch has simulated so far (`bench.outcomes_records.StoredMemo`)."""

    def parts(self, tasks: Sequence[Task]) -> Iterator[Part]: ...


ONE_ATTEMPT = 1  # the paper's robot: `FLSPegTransfer_single.py` (BerkeleyAutomation/FLSpegtransferHO)
# runs `move_block` once per action order and skips an order whose block it no longer finds on its peg
WITH_RECOVERY = 1 + REGRASPS  # pegbt's trees (`trees/shared/one_transfer.yaml`)


def attempts_for(outcomes: Outcomes) -> int:
    """Attempts per simulated transfer under the real outcomes' protocol: one where a trial's attempts end
    at a block lost for good (the paper's robot never retried a transfer), else pegbt's recovery."""
    return ONE_ATTEMPT if outcomes.attempts_end_at_lost_block else WITH_RECOVERY


def registered_for(outcomes: Outcomes) -> bool:
    """Whether the simulated arms are registered to the camera as the paper's robot registered its own
    (`registration`): under the paper's protocol, the counting its table states. pegbt's own outcomes were
    run on the work cell's figures."""
    return outcomes.attempts_end_at_lost_block


def _run(task: Task, attempts: int = WITH_RECOVERY, registered: bool = False) -> list[TransferResult]:
    """One transfer simulated in each world, with up to `attempts` picks, the arms `registered` as the
    paper's were or not; a motion the planner refuses (a target out of reach in that world) is a transfer
    that failed where it started, never the end of the whole fit. A way back whose block was lost is
    skipped only under the paper's protocol (one attempt); pegbt's trees try it and fail at `sense`."""
    return _run_job([task], attempts, registered)[0]


def _in_trials(attempts: int, variant: str) -> bool:
    """Whether a task's transfer is simulated as part of its trial (`trialsim`): under pegbt's trees (the
    paper's robot skipped a lost block and never recovered), for the variants `in_order` names."""
    return attempts != ONE_ATTEMPT and in_order(variant)


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


def _jobs(tasks: Sequence[Task], attempts: int, workers: int = 1) -> list[Job]:
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
        groups.setdefault(trial if _in_trials(attempts, variant) else i, []).append(i)

    def played(group: list[int]) -> int:
        variant = tasks[group[0]][1]
        if not _in_trials(attempts, variant):
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


def _run_job(tasks: Sequence[Task], attempts: int, registered: bool) -> list[list[TransferResult]]:
    """`tasks` (one task, or the seeds of one trial in the same worlds) simulated: per task, per world."""
    worlds, variant, condition, seed = tasks[0]
    if _in_trials(attempts, variant):
        layout, _ = trial_of(variant, seed)
        indices = [trial_of(variant, task[3])[1] for task in tasks]
        played = simulate_trial(worlds, variant, condition, layout, max(indices) + 1, attempts, registered)
        return [played[index] for index in indices]
    assert len(tasks) == 1  # only a trial's seeds are grouped
    replay = Replay()
    results = []
    for world in worlds:
        try:
            result = simulate_transfer(
                world, variant, condition, seed, replay, attempts=attempts, registered=registered
            )
        except PegbtError:
            result = TransferResult(False, "reach", 0.0)
        results.append(result if attempts == ONE_ATTEMPT else replace(result, skipped=False))
    return [results]


def _job_tasks(tasks: Sequence[Task], job: Job) -> list[Task]:
    """The tasks of `job`, each with the job's part of its worlds."""
    return [(tasks[i][0][job.worlds], *tasks[i][1:]) for i in job.tasks]


def _gathered(tasks: Sequence[Task], done: Iterable[Part]) -> list[list[TransferResult]]:
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
        self._run = partial(_run_job, attempts=attempts, registered=registered)

    def __call__(self, tasks: Sequence[Task]) -> list[list[TransferResult]]:
        return _gathered(tasks, self.parts(tasks))

    def parts(self, tasks: Sequence[Task]) -> Iterator[Part]:
        """Each job of `tasks` with its results, as the workers finish them."""
        jobs = _jobs(tasks, self._attempts, self._workers)
        if self._pool is None:
            for job in jobs:
                yield job, self._run(_job_tasks(tasks, job))
            return
        futures = {self._pool.submit(self._run, _job_tasks(tasks, job)): job for job in jobs}
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
        self._run = partial(_run_job, attempts=attempts, registered=registered)

    def __call__(self, tasks: Sequence[Task]) -> list[list[TransferResult]]:
        return _gathered(tasks, self.parts(tasks))

    def parts(self, tasks: Sequence[Task]) -> Iterator[Part]:
        """Each job of `tasks` with its results, as the cluster's workers finish them; every job is
        submitted at once, so a batch keeps as many workers busy as it has jobs."""
        from distributed import as_completed as as_done

        jobs = _jobs(tasks, self._attempts, self._workers)
        futures = self._client.map(self._run, [_job_tasks(tasks, job) for job in jobs], pure=False)
        job_of = {future.key: job for future, job in zip(futures, jobs)}
        try:
            for future, outcome in as_done(futures, loop=self._client.loop, with_results=True):
                yield job_of[future.key], outcome
        finally:
            self._client.cancel(futures)

    def close(self) -> None:
        self._client.close()


def simulate_cells(
    mapper: Mapper, worlds: Sequence[WorldEffects], keys: Iterable[Key], transfers: int, first_seed: int = 0
) -> list[dict[Key, SimCounts]]:
    """For each world, `transfers` simulated transfers of each cell (seeds `first_seed`…), as counts."""
    keys = list(keys)
    tasks = [
        (tuple(worlds), variant, condition, first_seed + seed)
        for variant, condition in keys
        for seed in range(transfers)
    ]
    results = iter(mapper(tasks))
    out: list[dict[Key, SimCounts]] = [{key: SimCounts() for key in keys} for _ in worlds]
    for key in keys:
        for _ in range(transfers):
            for per_cell, result in zip(out, next(results)):
                per_cell[key].add(result)
    return out
