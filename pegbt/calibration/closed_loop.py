"""Calibration in the loop on the simulator: command the peg-transfer waypoints, measure where the tip went.

The arm is streamed along straight lines in joint space between the desired waypoints (10 ms samples at
half the planner's velocity), resting `SETTLE_S` at each; with a model, every sample goes through the
`Compensator` (Alg. 1, one streamed step per sample) and the compensated samples are what is sent. After
each rest the physical joints are read from `fiducial_js` and the tool-tip error is the distance that
forward kinematics puts between them and the desired joints.

Each run gets a fresh simulator (`pegbt sim --lockstep --no-world --physics PHYSICS`): its arm starts
settled at the default joints with no history, which is exactly what `Compensator.reset` assumes. The
model comes from a recording collected from a simulator of the same physics (`collect_on_simulator`),
never from the preset itself: the simulator is treated as a robot whose cables are unknown.
"""

from __future__ import annotations

from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path

import numpy as np
from numpy.typing import NDArray

from pegbt.calibration.base import CalibrationModel
from pegbt.calibration.collect import SETTLE_S, collect, move_and_settle, straight_move
from pegbt.calibration.compensation import Compensator
from pegbt.motion.kinematics import tip_position
from pegbt.sim.process import SimProcess
from pegbt.transport import ArmClient, SimClock, connect
from pegbt.transport.codec import TrajectoryPoints

Array = NDArray[np.float64]


@contextmanager
def simulated_arm(arm: str, physics: str = "dvrk-real") -> Iterator[tuple[ArmClient, SimClock]]:
    """A fresh lockstep simulator of the arms alone, and a client of `arm` on it."""
    with SimProcess(["--lockstep", "--no-world", "--physics", physics]) as sim:
        link = connect([sim.endpoint])
        try:
            clock = SimClock(link)
            client = ArmClient(link, arm, clock=clock)
            client.wait_until_ready()
            yield client, clock
        finally:
            link.close()


def collect_on_simulator(
    arm: str, out: str | Path, count: int, seed: int = 0, physics: str = "dvrk-real"
) -> Path:
    """A calibration recording of `count` set-points collected from a simulator with `physics`."""
    with simulated_arm(arm, physics) as (client, clock):
        return collect(client, clock, out, count, seed)


def desired_samples(start: Array, goal: Array, client: ArmClient) -> Array:
    """10 ms samples of the straight line from `start` to `goal`, then `SETTLE_S` resting at `goal`."""
    period = client.settings.control_period
    steps = int(round(float(straight_move(start, goal, client.settings).t[-1]) / period))
    line = start + np.outer(np.arange(1, steps + 1) / steps, goal - start)
    rest = np.tile(goal, (int(round(SETTLE_S / period)), 1))
    return np.vstack([line, rest])


def run_waypoints(
    client: ArmClient, clock: SimClock, goals: Array, model: CalibrationModel | None = None
) -> Array:
    """Tool-tip error (mm) at each of `goals` (K, 6), reached uncompensated or through `model`."""
    period = client.settings.control_period
    current = client.setpoint_js.position
    compensator = None
    if model is not None:
        compensator = Compensator(model, settings=client.settings)
        compensator.reset(current)
    errors = []
    for goal in goals:
        desired = desired_samples(current, goal, client)
        commands = desired if compensator is None else np.array([compensator.step(q) for q in desired])
        trajectory = TrajectoryPoints(period * np.arange(1, len(commands) + 1), commands)
        move_and_settle(client, clock, trajectory, settle_s=0.0)
        errors.append(1000.0 * np.linalg.norm(tip_position(client.fiducial_js.position) - tip_position(goal)))
        current = goal
    return np.array(errors)


def simulator_tip_errors(
    arm: str, goals: Array, model: CalibrationModel | None = None, physics: str = "dvrk-real"
) -> Array:
    """`run_waypoints` for `arm` on a fresh simulator with `physics`."""
    with simulated_arm(arm, physics) as (client, clock):
        return run_waypoints(client, clock, goals, model)
