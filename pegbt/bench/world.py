"""`pegbt bench world`: the cost of one world step and of one depth capture.

The world runs the reference's unilateral trial (12 transfers by PSM1, PSM2 parked) with scripted
vertical tools at the 10 ms control period; only `World.update` is timed. The camera captures the
starting scene ten times. Medians, with the 99th percentile of the step.
"""

from __future__ import annotations

import time
from collections.abc import Mapping
from typing import TYPE_CHECKING

import numpy as np

from pegbt.bench import Figures

if TYPE_CHECKING:
    from pegbt.sim.events import Event
    from pegbt.sim.tools import ToolState

STEP = 0.01


def run() -> Figures:
    from pegbt.sim.camera import DepthCamera
    from pegbt.sim.scripted import Driver, grasp_candidate_facing, parked, transfer_keyframes
    from pegbt.sim.world import World
    from pegbt.workcell import UNILATERAL_ORDER

    world = World(seed=0)
    durations: list[float] = []
    update, clock = world.update, time.perf_counter

    def timed_update(time: float, tools: Mapping[str, ToolState]) -> list[Event]:
        start = clock()
        events = update(time, tools)
        durations.append(clock() - start)
        return events

    world.update = timed_update  # type: ignore[method-assign]
    driver = Driver(world, step=STEP)
    for start_peg, goal_peg in UNILATERAL_ORDER:
        block = next(b.index for b in world.blocks if b.peg == start_peg and b.state == "on_peg")
        driver.play(
            {"PSM1": transfer_keyframes(world, block, goal_peg, grasp_candidate_facing(world, block, "PSM1"))}
        )
    driver.play({"PSM1": [parked(world, "PSM1")]})
    steps = np.array(durations)
    placed = world.events.of_kind("place")

    camera = DepthCamera(seed=0)
    captures, clouds = [], []
    for _ in range(10):
        start = time.perf_counter()
        clouds.append(camera.capture(world))
        captures.append(time.perf_counter() - start)
    return {
        "update_us_p50": float(np.median(steps) * 1e6),
        "update_us_p99": float(np.percentile(steps, 99) * 1e6),
        "world_realtime_factor": float(len(steps) * STEP / steps.sum()),
        "steps": len(steps),
        "transfers_placed": len(placed),
        "collisions": len(world.events.of_kind("collision")),
        "capture_ms_p50": float(np.median(captures) * 1e3),
        "capture_points": int(np.median([len(cloud) for cloud in clouds])),
        "rays_per_capture": camera.ray_count,
    }
