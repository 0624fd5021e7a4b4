"""Time-optimal rest-to-rest joint moves along the straight line in joint space (ruckig, phase-synchronised,
infinite jerk): the short moves of a handover (the receiver's way to the meeting and its descent, the
giver's rise), which the rest-to-rest cubics (`pegbt.motion.cubic`) take 1.22 × as long over, since a cubic
reaches its acceleration limit only at its ends. Same path, same velocity and acceleration limits.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np
from numpy.typing import ArrayLike

from pegbt.errors import PegbtError
from pegbt.motion.limits import ArmSettings
from pegbt.motion.trajectory import Trajectory, concatenate


def quickest_move(q_from: ArrayLike, q_to: ArrayLike, settings: ArmSettings) -> Trajectory:
    """The quickest rest-to-rest move from `q_from` to `q_to` on the straight joint line under the planner's
    limits, stretched to a whole number of control periods and sampled at it."""
    import ruckig

    start, goal = np.asarray(q_from, dtype=float), np.asarray(q_to, dtype=float)
    period = settings.control_period
    generator, inputs = ruckig.Ruckig(len(start)), ruckig.InputParameter(len(start))
    inputs.current_position, inputs.target_position = start.tolist(), goal.tolist()
    inputs.max_velocity = settings.planner_velocity.tolist()
    inputs.max_acceleration = settings.planner_acceleration.tolist()
    inputs.max_jerk = [math.inf] * len(start)
    inputs.synchronization = ruckig.Synchronization.Phase
    trajectory = _calculate(generator, inputs)
    inputs.minimum_duration = max(1, math.ceil(trajectory.duration / period - 1e-9)) * period
    trajectory = _calculate(generator, inputs)
    steps = round(inputs.minimum_duration / period)
    t = np.arange(steps + 1) * period
    q, qd, qdd = (np.array(values) for values in zip(*(trajectory.at_time(float(s)) for s in t)))
    q[-1], qd[[0, -1]], qdd[-1] = goal, 0.0, 0.0
    return Trajectory(t, q, qd, qdd)


def quickest_through(
    waypoints: ArrayLike, settings: ArmSettings, names: list[str] | None = None
) -> Trajectory:
    """`quickest_move`s through joint `waypoints` (K, 6), stopping at each; `names` label them in errors."""
    q = np.asarray(waypoints, dtype=float)
    if q.ndim != 2 or q.shape[1] != 6 or len(q) < 2:
        raise PegbtError(
            f"expected at least two joint waypoints of shape (K, 6), got {q.shape}", field="waypoints"
        )
    for name, row in zip(names or [f"waypoint {i}" for i in range(len(q))], q):
        settings.require_within(row, name)
    return concatenate([quickest_move(a, b, settings) for a, b in zip(q[:-1], q[1:])])


def _calculate(generator: Any, inputs: Any) -> Any:
    import ruckig

    trajectory = ruckig.Trajectory(inputs.degrees_of_freedom)
    result = generator.calculate(inputs, trajectory)
    if result not in (ruckig.Result.Working, ruckig.Result.Finished):
        raise PegbtError(f"ruckig could not time a rest-to-rest move: {result}", field="trajectory")
    return trajectory
