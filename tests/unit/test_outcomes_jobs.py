"""A batch cut into jobs the workers finish together: a trial's seeds stay one job in order, a job with
many worlds is cut by its worlds, and the results come back in the tasks' order whatever the cut."""

from __future__ import annotations

from pegbt.sim.world_effects import WorldEffects
from pegbt.sim2real.outcomes import simulate
from pegbt.sim2real.outcomes.phasesim import TransferResult

WORLDS = tuple(WorldEffects.of({"peg_compliance": {"deflection": 0.0004 * k}}) for k in range(1, 8))
UNILATERAL = [(WORLDS, "unilateral", "uncalibrated", seed) for seed in range(16)]


def _played(tasks: list[simulate.Task]) -> list[list[TransferResult]]:
    """A stand-in for `_run_job`: each task's transfer per world, named by world and seed."""
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
    whole = simulate._jobs(UNILATERAL, simulate.WITH_RECOVERY)
    assert sorted(job.size for job in whole) == [4 * 7, 12 * 7]  # two trials: 12 to 4 on two workers
    cut = simulate._jobs(UNILATERAL, simulate.WITH_RECOVERY, workers=2)
    assert _makespan([job.size for job in cut], 2) <= 1.15 * 16 * 7 / 2
    for job in cut:  # a trial's seeds are still played together, in one part of its worlds
        seeds = {UNILATERAL[i][3] // 12 for i in job.tasks}
        assert len(seeds) == 1 and len(job.tasks) == (12 if seeds == {0} else 4)


def test_results_come_back_in_the_tasks_order_whatever_the_cut() -> None:
    expected = _played(UNILATERAL)
    for workers in (1, 2, 3, 8):
        jobs = simulate._jobs(UNILATERAL, simulate.WITH_RECOVERY, workers)
        done = [_played(simulate._job_tasks(UNILATERAL, job)) for job in jobs]
        assert simulate._gathered(UNILATERAL, jobs, done) == expected


def test_a_task_alone_keeps_its_worlds_together_on_one_worker() -> None:
    bilateral = [(WORLDS, "bilateral", "uncalibrated", seed) for seed in range(40)]
    jobs = simulate._jobs(bilateral, simulate.WITH_RECOVERY, workers=2)
    assert all(job.worlds == slice(0, len(WORLDS)) for job in jobs)  # 40 jobs share well already
