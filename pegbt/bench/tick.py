"""`pegbt bench tick`: what a simulated tick costs, where `pegbt bench sim2real-outcomes` spends its time.

The concealed campaign of that benchmark simulates, per seed, 120 transfers of each of the six cells in
every family's world at once (`phasesim`: the arm with `dvrk-real` cables ticked at the control
period, the world updated each tick). This benchmark runs a fixed slice of it in this process: the first
`TRANSFERS` seeds of each cell, the same worlds, the same seeds, and reports the CPU per transfer, per
simulated second (summed over the worlds) and per concealed seed (120 transfers a cell), with the cable
model's step alone (`dvrk-real` PSM1 along a random walk of commands). Each figure is the median of
`REPEATS` runs. There is no same-run baseline: the previous code is another checkout, so compare this
benchmark's figures at two commits on the same machine, run one after the other.
"""

from __future__ import annotations

import statistics
import time

import numpy as np

from pegbt.bench import Figures

TRANSFERS = 2  # seeds per cell: 12 transfers, each in every family's world
REPEATS = 3
STEPS = 5000  # cable model steps timed
CONCEALED_TRANSFERS = 120  # per cell and seed in `pegbt bench sim2real-outcomes`


def _campaign_slice() -> tuple[float, float, int, int]:
    """(CPU s, simulated s summed over worlds, transfers, worlds) of the concealed campaign's first seeds."""
    from pegbt.bench.sim2real_outcomes import CELLS, FAMILIES, REAL_SEED
    from pegbt.sim.world_effects import WorldEffects
    from pegbt.sim2real.outcomes.workers import LocalMapper

    worlds = tuple(WorldEffects.of(FAMILIES[family]) for family in FAMILIES)
    tasks = [(worlds, v, c, REAL_SEED + seed) for v, c in CELLS for seed in range(TRANSFERS)]
    mapper = LocalMapper(0)
    started = time.process_time()
    results = mapper(tasks)
    cpu = time.process_time() - started
    return cpu, sum(r.seconds for per_task in results for r in per_task), len(tasks), len(worlds)


def _step_us() -> float:
    """Microseconds of CPU per `ArmPhysics.step` of `dvrk-real` PSM1."""
    from pegbt.physics import ArmPhysics

    physics = ArmPhysics.load("dvrk-real", "PSM1")
    rng = np.random.default_rng(0)
    commands = np.cumsum(rng.normal(0.0, 0.001, (STEPS, 6)), axis=0) + [0.0, 0.0, 0.12, 0.0, 0.0, 0.0]
    physics.reset(commands[0])
    started = time.process_time()
    for row in commands:
        physics.step(row, 0.01)
    return (time.process_time() - started) / STEPS * 1e6


def run() -> Figures:
    _campaign_slice()  # warm: the imports and skills a worker process pays once
    slices = [_campaign_slice() for _ in range(REPEATS)]
    cpu = statistics.median(s[0] for s in slices)
    simulated, transfers, worlds = slices[0][1], slices[0][2], slices[0][3]
    steps = statistics.median(_step_us() for _ in range(REPEATS))
    cells = transfers // TRANSFERS
    return {
        "transfers": transfers,
        "worlds_per_transfer": worlds,
        "cpu_s_median": cpu,
        "cpu_ms_per_transfer": cpu / transfers * 1e3,
        "cpu_ms_per_simulated_s": cpu / simulated * 1e3,
        "simulated_s": simulated,
        "concealed_seed_cpu_s_estimate": cpu / transfers * cells * CONCEALED_TRANSFERS,
        "cable_step_us_median": steps,
        "repeats": REPEATS,
    }
