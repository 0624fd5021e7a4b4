"""Many trials of one cell (variant × condition), seeds S..S+N−1, in worker processes.

Each trial starts its own simulator on its own free port, so trials share nothing and a seed gives the
same result whichever worker runs it, in whatever order. Two workers keep both cores of a small machine
busy (a trial's executive and its simulator take turns in lockstep, so each pair uses about one core).
"""

from __future__ import annotations

import multiprocessing
import os
import threading
import time
from collections.abc import Callable
from concurrent.futures import ProcessPoolExecutor, as_completed
from dataclasses import dataclass
from pathlib import Path

from pegbt.evaluation.faultgen import write_fault_plan
from pegbt.evaluation.trial import TrialRecord, TrialSpec, run_trial


@dataclass(frozen=True)
class Cell:
    """What to run: one variant and condition over `trials` seeds from `seed`, with faults as asked."""

    variant: str
    condition: str
    trials: int
    seed: int = 0
    faults: Path | None = None  # one plan for every trial (its probabilistic faults vary with the seed)
    inject_faults: bool = False  # a plan per seed from `pegbt.evaluation.faultgen`
    realtime: bool = False  # simulators in real time, runs on the wall clock (else lockstep)
    interface: str = "pegbt"
    world_effects: Path | None = (
        None  # a world file for every trial's simulator (`pegbt sim --world-effects`)
    )
    camera: str = "stream"
    speed: float = 1.0  # the fraction of the planner's speed (`pegbt run --speed`)
    robot_clock_offset: float = 0.0  # s the simulated robot's clock is from this one's (`--interface dvrk`)
    protocol: str = "pegbt"  # the trees' own, or the reference paper's (`pegbt run --protocol`)

    @property
    def name(self) -> str:
        return (
            f"{self.variant}-{self.condition}"
            + ("-faults" if self.faults or self.inject_faults else "")
            + ("-realtime" if self.realtime else "")
            + ("" if self.interface == "pegbt" else f"-{self.interface}")
            + ("" if self.camera == "stream" else f"-{self.camera}")
            + ("" if self.speed == 1.0 else f"-speed{self.speed:g}")
            + ("" if not self.robot_clock_offset else f"-clock{self.robot_clock_offset:+g}")
            + ("" if self.protocol == "pegbt" else f"-{self.protocol}")
        )

    @property
    def seeds(self) -> range:
        return range(self.seed, self.seed + self.trials)


def trial_specs(cell: Cell, out: Path, keep_logs: bool = False) -> list[TrialSpec]:
    """One spec per seed; tick logs under `out/logs/`, generated fault plans under `out/faults/`."""
    logs = out / "logs"
    logs.mkdir(parents=True, exist_ok=True)
    specs = []
    for seed in cell.seeds:
        plan = write_fault_plan(out / "faults" / cell.variant, seed) if cell.inject_faults else cell.faults
        log = logs / f"{cell.name}-{seed}.jsonl"
        specs.append(
            TrialSpec(
                cell.variant,
                cell.condition,
                seed,
                log,
                plan,
                keep_logs,
                realtime=cell.realtime,
                interface=cell.interface,
                world_effects=cell.world_effects,
                camera=cell.camera,
                speed=cell.speed,
                robot_clock_offset=cell.robot_clock_offset,
                protocol=cell.protocol,
            )
        )
    return specs


def run_trials(
    specs: list[TrialSpec], workers: int = 2, done: Callable[[TrialRecord], None] | None = None
) -> list[TrialRecord]:
    """Run every spec (in `workers` processes; in this one if 1) and return their records in spec order;
    `done` is called with each record as it finishes."""
    if workers <= 1 or len(specs) <= 1:
        records = []
        for spec in specs:
            records.append(run_trial(spec))
            if done is not None:
                done(records[-1])
        return records
    by_seed: dict[int, TrialRecord] = {}
    context = multiprocessing.get_context(
        "spawn"
    )  # a clean interpreter: no inherited zenoh session or threads
    with ProcessPoolExecutor(
        max_workers=min(workers, len(specs)),
        mp_context=context,
        initializer=_exit_with_parent,
        initargs=(os.getpid(),),
    ) as pool:
        futures = [pool.submit(run_trial, spec) for spec in specs]
        try:
            for future in as_completed(futures):
                record = future.result()
                by_seed[record.seed] = record
                if done is not None:
                    done(record)
        except BaseException:
            for future in futures:
                future.cancel()
            raise
    return [by_seed[spec.seed] for spec in specs]


def _exit_with_parent(parent: int) -> None:
    """In a worker: exit as soon as `parent` is gone. A terminated or killed `pegbt eval` would otherwise
    leave its workers running their trials (and writing its logs) for minutes; the worker's simulator
    stops with it (`SimProcess`)."""

    def watch() -> None:
        while os.getppid() == parent:
            time.sleep(0.5)
        os._exit(1)

    threading.Thread(target=watch, name="parent-watch", daemon=True).start()
