"""Time-optimal rest-to-rest joint moves along the straight line in joint space (ruckig on the fraction
of the line travelled, infinite jerk): the short moves of a handover (the receiver's way to the meeting
and its descent, the giver's rise), which the rest-to-rest cubics (`pegbt.motion.cubic`) take 1.22 × as
long over, since a cubic reaches its acceleration limit only at its ends. Same path, same limits.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np
from numpy.typing import ArrayLike

from pegbt.errors import PegbtError
from pegbt.motion.cubic import checked_waypoints
from pegbt.motion.limits import ArmSettings
from pegbt.motion.trajectory import Trajectory, concatenate

# rad or m: a joint's travel below which it is taken as still; far under the encoders' resolution, and the
# fraction-of-line limits of a travel of 1e-15 overflow ruckig's arithmetic
STILL = 1e-9


def quickest_move(q_from: ArrayLike, q_to: ArrayLike, settings: ArmSettings) -> Trajectory:
    """The quickest rest-to-rest move from `q_from` to `q_to` on the straight joint line under the planner's
    limits, stretched to a whole number of control periods and sampled at it: the time-optimal profile of
    the fraction of the line travelled (ruckig, one degree of freedom), under the limits of the joint that
    binds, so every joint stays on the line and within its own limits."""
    import ruckig

    start, goal = np.asarray(q_from, dtype=float), np.asarray(q_to, dtype=float)
    delta, period = goal - start, settings.control_period
    moving = np.abs(delta) > STILL
    if not moving.any():
        return Trajectory(np.array([0.0, period]), np.stack([start, goal]), *np.zeros((2, 2, len(start))))
    generator, inputs = ruckig.Ruckig(1), ruckig.InputParameter(1)
    inputs.current_position, inputs.target_position = [0.0], [1.0]
    inputs.max_velocity = [float(np.min(settings.planner_velocity[moving] / np.abs(delta[moving])))]
    inputs.max_acceleration = [float(np.min(settings.planner_acceleration[moving] / np.abs(delta[moving])))]
    inputs.max_jerk = [math.inf]
    fastest = _calculate(generator, inputs).duration
    inputs.minimum_duration = max(1, math.ceil(fastest / period - 1e-9)) * period
    profile = _calculate(generator, inputs)
    t = np.arange(round(inputs.minimum_duration / period) + 1) * period
    s, sd, sdd = (np.array(values)[:, 0] for values in zip(*(profile.at_time(float(time)) for time in t)))
    s[-1], sd[[0, -1]], sdd[-1] = 1.0, 0.0, 0.0
    return Trajectory(t, start + s[:, None] * delta, sd[:, None] * delta, sdd[:, None] * delta)


def quickest_through(
    waypoints: ArrayLike, settings: ArmSettings, names: list[str] | None = None
) -> Trajectory:
    """`quickest_move`s through joint `waypoints` (K, 6), stopping at each; `names` label them in errors."""
    q = checked_waypoints(waypoints, settings, names)
    return concatenate([quickest_move(a, b, settings) for a, b in zip(q[:-1], q[1:])])


def _calculate(generator: Any, inputs: Any) -> Any:
    import ruckig

    trajectory = ruckig.Trajectory(inputs.degrees_of_freedom)
    try:
        result = generator.calculate(inputs, trajectory)
    except ruckig.RuckigError as error:
        raise PegbtError(f"ruckig could not time a rest-to-rest move: {error}", field="trajectory") from None
    if result not in (ruckig.Result.Working, ruckig.Result.Finished):
        raise PegbtError(f"ruckig could not time a rest-to-rest move: {result}", field="trajectory")
    return trajectory
