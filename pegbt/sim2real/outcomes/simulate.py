"""Many simulated transfers per cell, summed into counts; what a worker runs (`run_job`), wherever it runs
(`workers`).

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

from collections.abc import Iterable, Sequence
from dataclasses import dataclass, field, replace
from typing import Protocol

import numpy as np

from pegbt.errors import PegbtError
from pegbt.sim.world_effects import WorldEffects
from pegbt.sim2real.outcomes.cells import PHASES, Outcomes
from pegbt.sim2real.outcomes.phasesim import REGRASPS, Replay, TransferResult, simulate_transfer
from pegbt.sim2real.outcomes.trialsim import in_order, simulate_trial, trial_of

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
    return run_job([task], attempts, registered)[0]


def in_trials(attempts: int, variant: str) -> bool:
    """Whether a task's transfer is simulated as part of its trial (`trialsim`): under pegbt's trees (the
    paper's robot skipped a lost block and never recovered), for the variants `in_order` names."""
    return attempts != ONE_ATTEMPT and in_order(variant)


def run_job(tasks: Sequence[Task], attempts: int, registered: bool) -> list[list[TransferResult]]:
    """`tasks` (one task, or the seeds of one trial in the same worlds) simulated: per task, per world."""
    worlds, variant, condition, seed = tasks[0]
    if in_trials(attempts, variant):
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
