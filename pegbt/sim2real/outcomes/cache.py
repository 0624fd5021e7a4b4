"""Simulated transfers remembered by their inputs, so a transfer is simulated once however often it recurs.

A simulated transfer is a function of the world's effects (kinds and parameters), the variant, the
condition, the seed and the mapper's attempts, and of nothing else (`phasesim` draws every random number
from the seed; `tests/unit/test_outcomes_cache.py` holds it to that). The fit simulates the same candidate
worlds on the same seeds whatever the real outcomes are, so the diagnoses of a benchmark, which differ only
in their real outcomes, share most of their simulations: one `MemoMapper` over the worker pool serves them
all. The key is the simulation's inputs, never its code: a changed simulator starts with an empty memo.
"""

from __future__ import annotations

from collections.abc import Iterable, Sequence

from pegbt.sim.world_effects import WorldEffects
from pegbt.sim2real.outcomes.phasesim import TransferResult
from pegbt.sim2real.outcomes.simulate import Mapper, Task
from pegbt.sim2real.outcomes.workers import Job, Part, PartedMapper

Known = tuple[WorldEffects, str, str, int]  # world, variant, condition, seed


class MemoMapper:
    """`mapper` (whose attempts are fixed, so they need no key) with every transfer it simulated remembered
    per world, variant, condition and seed; `simulated` counts the transfers it passed on. A task's worlds
    already known are left out of what it passes on, so the arm is simulated only for the others."""

    def __init__(self, mapper: Mapper) -> None:
        self.mapper = mapper
        self.known: dict[Known, TransferResult] = {}
        self.simulated = 0

    def __call__(self, tasks: Sequence[Task]) -> list[list[TransferResult]]:
        new: list[Task] = []
        for worlds, variant, condition, seed in tasks:
            unknown = tuple(w for w in worlds if (w, variant, condition, seed) not in self.known)
            if unknown:
                new.append((unknown, variant, condition, seed))
        learnt: list[tuple[Known, TransferResult]] = []
        for job, outcome in self._parts(new):
            got = [
                ((w, *new[i][1:]), r)
                for i, results in zip(job.tasks, outcome)
                for w, r in zip(new[i][0][job.worlds], results)
            ]
            self.keep(got)
            learnt += got
        simulated = len(learnt)
        self.simulated += simulated
        self.batch(simulated)
        return [
            [self.known[(w, variant, condition, seed)] for w in worlds]
            for worlds, variant, condition, seed in tasks
        ]

    def _parts(self, tasks: Sequence[Task]) -> Iterable[Part]:
        """The mapper's jobs as each is done if it hands them back so, else the whole call as one."""
        if isinstance(self.mapper, PartedMapper):
            return self.mapper.parts(tasks)
        whole = Job(tuple(range(len(tasks))), slice(None), sum(len(worlds) for worlds, *_ in tasks))
        return [(whole, self.mapper(tasks))] if tasks else []

    def keep(self, learnt: Sequence[tuple[Known, TransferResult]]) -> None:
        """Remember the transfers a job simulated, as it is done (a subclass may also keep them elsewhere)."""
        self.known.update(learnt)

    def batch(self, simulated: int) -> None:
        """Called after each call with the transfers it simulated (a hook for progress)."""
