"""A batch cut into jobs the workers finish together: a trial's seeds stay one job in order, a job with
many worlds is cut by its worlds, and the results come back in the tasks' order whatever the cut."""

from __future__ import annotations

import pytest

from pegbt.sim.world_effects import WorldEffects
from pegbt.sim2real.outcomes import simulate, workers
from pegbt.sim2real.outcomes.phasesim import TransferResult

WORLDS = tuple(WorldEffects.of({"peg_compliance": {"deflection": 0.0004 * k}}) for k in range(1, 8))
UNILATERAL = [(WORLDS, "unilateral", "uncalibrated", seed) for seed in range(16)]


def _played(tasks: list[simulate.Task]) -> list[list[TransferResult]]:
    """A stand-in for `simulate.run_job`: each task's transfer per world, named by world and seed."""
    return [
        [TransferResult(True, None, float(WORLDS.index(w) * 100 + seed)) for w in worlds]
        for worlds, _, _, seed in tasks
    ]


def _makespan(sizes: list[int], workers: int) -> int:
    """The busiest worker's load when each job goes to the least loaded worker, largest first."""
    loads = [0] * workers
    for size in sorted(sizes, reverse=True):
        loads[loads.index(min(loads))] += size
    return max(loads)


def test_one_unilateral_cell_is_shared_evenly_by_two_workers() -> None:
    whole = workers.cut_into_jobs(UNILATERAL, simulate.WITH_RECOVERY)
    assert sorted(job.size for job in whole) == [4 * 7, 12 * 7]  # two trials: 12 to 4 on two workers
    cut = workers.cut_into_jobs(UNILATERAL, simulate.WITH_RECOVERY, workers=2)
    assert _makespan([job.size for job in cut], 2) <= 1.15 * 16 * 7 / 2
    for job in cut:  # a trial's seeds are still played together, in one part of its worlds
        seeds = {UNILATERAL[i][3] // 12 for i in job.tasks}
        assert len(seeds) == 1 and len(job.tasks) == (12 if seeds == {0} else 4)


def test_results_come_back_in_the_tasks_order_whatever_the_cut() -> None:
    expected = _played(UNILATERAL)
    for count in (1, 2, 3, 8):
        jobs = workers.cut_into_jobs(UNILATERAL, simulate.WITH_RECOVERY, count)
        done = [(job, _played(workers.job_tasks(UNILATERAL, job))) for job in jobs]
        assert workers.gathered(UNILATERAL, done) == expected
        assert workers.gathered(UNILATERAL, reversed(done)) == expected  # in the order they were done


def test_a_task_alone_keeps_its_worlds_together_on_one_worker() -> None:
    bilateral = [(WORLDS, "bilateral", "uncalibrated", seed) for seed in range(40)]
    jobs = workers.cut_into_jobs(bilateral, simulate.WITH_RECOVERY, workers=2)
    assert all(job.worlds == slice(0, len(WORLDS)) for job in jobs)  # 40 jobs share well already


def test_a_job_larger_than_two_minutes_of_a_core_is_cut_even_for_one_worker() -> None:
    worlds = tuple(WorldEffects.of({"peg_compliance": {"deflection": 0.00005 * k}}) for k in range(1, 61))
    trial = [(worlds, "unilateral", "uncalibrated", seed) for seed in range(12)]  # 12 x 60 = 720
    jobs = workers.cut_into_jobs(trial, simulate.WITH_RECOVERY)
    assert [job.size for job in jobs] == [360, 360]
    assert [job.worlds for job in jobs] == [slice(0, 30), slice(30, 60)]
    assert all(job.tasks == tuple(range(12)) for job in jobs)  # each part plays the whole trial in order


def test_the_local_mapper_hands_back_every_job_once_and_its_call_gathers_them(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    monkeypatch.setattr(workers, "run_job", lambda tasks, attempts, registered: _played(tasks))
    mapper = workers.LocalMapper(0)
    monkeypatch.setattr(workers, "LARGEST_JOB", 30)  # the 12-seed trial in 3 parts, the 4-seed one in 1
    parts = list(mapper.parts(UNILATERAL))
    assert sorted((job.worlds.start, job.tasks[0]) for job, _ in parts) == [(0, 0), (0, 12), (2, 0), (5, 0)]
    for job, outcome in parts:
        assert outcome == _played(workers.job_tasks(UNILATERAL, job))
    assert mapper(UNILATERAL) == _played(UNILATERAL)
