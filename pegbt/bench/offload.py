"""`pegbt bench offload`: whether a tree keeps ticking while a leaf's heavy work runs on a worker thread.

Two jobs the peg-transfer leaves hand to `pegbt.executive.work`: perception of a capture (board
registration and block search, Open3D) and a transfer (SQP plan with OSQP, then every 10 ms row
pre-compensated, numpy and Python). Each runs inline (as it did in the tick: the tick is late by the
whole job) and on the run's worker pool while this thread ticks every `PERIOD` (as the runner does in
real time), recording how late each tick wakes. Late ticks mean the job holds the GIL; the job's own
slow-down against inline says what sharing the core costs it. Medians over `REPEATS` runs of each.

Pre-compensation of the transfer's rows is also timed alone, in µs per 10 ms row: the whole trajectory
at once (`Compensator.trajectory`, what a transfer's preparation runs) and `step` row by row.
"""

from __future__ import annotations

import logging
import statistics
import time
from collections.abc import Callable
from functools import partial

import numpy as np

from pegbt.bench import Figures

PERIOD = 0.02  # s: the runner's default tick period
REPEATS = 5
COMPENSATION_REPEATS = 15
SEED = 3


def _jobs() -> dict[str, Callable[[], object]]:
    """The two jobs, on a seeded world: perceive a capture; plan and pre-compensate PSM1's first transfer."""
    from pegbt.behaviours.poses import transfer_for
    from pegbt.behaviours.resources.skills import SIMULATOR_CALIBRATION, Skills
    from pegbt.motion.ik import solve_ik
    from pegbt.perception.blocks import block_on_peg
    from pegbt.sim.camera import DepthCamera
    from pegbt.sim.world import World

    world = World(seed=SEED)
    cloud = DepthCamera(seed=SEED, include_arms=False).capture(world)
    skills = Skills("optimized", SIMULATOR_CALIBRATION)
    board = skills.registration.fit(cloud)
    blocks = skills.locator.locate(cloud, board)
    block = block_on_peg(blocks, 1)
    assert block is not None  # seed SEED's world has a block on peg 1
    grasp = skills.selectors["PSM1"].pick(block)
    assert grasp is not None
    waypoints = transfer_for(skills.cell, skills.motion, "PSM1", board, block, grasp, 7)
    motion = skills.arm("PSM1")
    assert motion.compensator is not None
    motion.compensator.reset(solve_ik(waypoints.poses[0], motion.settings))
    logging.getLogger("pegbt.calibration.compensation").setLevel(logging.ERROR)  # its clamp notes: not timed

    def perceive() -> object:
        return skills.locator.locate(cloud, skills.registration.fit(cloud))

    return {"perception": perceive, "transfer": partial(motion.prepare, partial(motion.transfer, waypoints))}


def _compensations(transfer: Callable[[], object]) -> Figures:
    """µs per row of pre-compensating the transfer's planned rows: at once, and row by row (medians)."""
    from pegbt.behaviours.resources.arm_motion import Prepared
    from pegbt.calibration.compensation import Compensator

    prepared = transfer()
    assert isinstance(prepared, Prepared) and prepared.compensator is not None
    rows, model = prepared.planned.q, prepared.compensator.model
    runs: dict[str, Callable[[Compensator], object]] = {
        "compensation_trajectory_us_per_row": lambda c: c.trajectory(rows),
        "compensation_step_us_per_row": lambda c: [c.step(row) for row in rows],
    }
    seconds: dict[str, list[float]] = {name: [] for name in runs}
    for _ in range(COMPENSATION_REPEATS):  # alternated: a change in the machine's load hits both alike
        for name, compensate in runs.items():
            compensator = Compensator(model, settings=prepared.compensator.settings)
            compensator.reset(rows[0])
            began = time.perf_counter()
            compensate(compensator)
            seconds[name].append(time.perf_counter() - began)
    figures: Figures = {"compensation_rows": len(rows)}
    for name, taken in seconds.items():
        figures[name] = statistics.median(taken) / len(rows) * 1e6
    return figures


def _ticking(job: Callable[[], object]) -> tuple[float, list[float]]:
    """Run `job` on a worker while this thread ticks every PERIOD: (job seconds, each tick's lateness)."""
    from pegbt.executive.work import WorkPool

    pool = WorkPool()
    try:
        submitted = time.perf_counter()
        running = pool.submit(job)
        late, due = [], submitted + PERIOD
        while not running.done:
            time.sleep(max(0.0, due - time.perf_counter()))
            late.append(time.perf_counter() - due)
            due = max(due + PERIOD, time.perf_counter())
        running.result()
        assert running.started is not None and running.finished is not None
        return running.finished - running.started, late
    finally:
        pool.close()


def run() -> Figures:
    figures: Figures = {"period_ms": PERIOD * 1e3}
    jobs = _jobs()
    for name, job in jobs.items():
        inline, threaded, late = [], [], []
        for _ in range(REPEATS):
            start = time.perf_counter()
            job()
            inline.append(time.perf_counter() - start)
            seconds, lateness = _ticking(job)
            threaded.append(seconds)
            late += lateness
        late_ms = np.array(late) * 1e3
        figures |= {
            f"{name}_inline_ms": statistics.median(inline) * 1e3,  # a tick that computes is this late
            f"{name}_worker_ms": statistics.median(threaded) * 1e3,
            f"{name}_ticks_while_computing": len(late) // REPEATS,
            f"{name}_tick_late_p50_ms": float(np.percentile(late_ms, 50)) if len(late_ms) else 0.0,
            f"{name}_tick_late_p99_ms": float(np.percentile(late_ms, 99)) if len(late_ms) else 0.0,
            f"{name}_tick_late_max_ms": float(late_ms.max()) if len(late_ms) else 0.0,
        }
    return figures | _compensations(jobs["transfer"])
