"""The joints the peg-transfer task asks of an arm: where calibration must be accurate.

`transfer_goals` gives the desired joints of the reference's twelve unilateral transfers (grasp, lifted
above the start peg, above the goal peg, lowered onto it), from the work cell's pegs through the motion
skills' waypoints and closed-form IK. `task_box` is the joint box a calibration recording should cover so
that a model fitted to it interpolates over the task instead of extrapolating.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

from pegbt.motion.ik import solve_ik
from pegbt.motion.limits import arm_settings
from pegbt.motion.waypoints import WAYPOINT_NAMES, transfer_waypoints
from pegbt.workcell import UNILATERAL_ORDER, workcell

Array = NDArray[np.float64]
BOARD_UP = np.array([0.0, 0.0, -1.0])  # the board frame's z points down into the board
# Margin around the task's joints (yaw, pitch in rad; insertion in m); the wrist is covered over a
# span much wider than its cable play, so that every hysteresis is driven through whole loops.
ARM_MARGIN = np.array([0.1, 0.1, 0.01])
WRIST_HALF_SPAN = 1.2


def transfer_goals(arm: str) -> Array:
    """Desired joints (12 × 4, 6) of the unilateral transfers, in order, for `arm`."""
    cell = workcell()
    board_to_arm = cell.board_to_arm(arm)
    tops = cell.pegs.tops @ board_to_arm[:3, :3].T + board_to_arm[:3, 3]
    up = board_to_arm[:3, :3] @ BOARD_UP
    settings = arm_settings(arm)
    goals = []
    for pick, place in UNILATERAL_ORDER:
        waypoints = transfer_waypoints(tops[pick], tops[place], up=up)
        for pose, name in zip(waypoints.poses, WAYPOINT_NAMES):
            goals.append(solve_ik(pose, settings, what=f"transfer {pick}→{place}: {name}"))
    return np.array(goals)


def task_box(arm: str) -> tuple[Array, Array]:
    """(lower, upper) joints a calibration recording for `arm` should span: the transfers' arm joints
    with a margin, the wrist ±1.2 rad about the middle of its range, all inside the joint limits."""
    goals, settings = transfer_goals(arm), arm_settings(arm)
    centre = (settings.lower + settings.upper) / 2
    lower = np.r_[goals[:, :3].min(axis=0) - ARM_MARGIN, centre[3:] - WRIST_HALF_SPAN]
    upper = np.r_[goals[:, :3].max(axis=0) + ARM_MARGIN, centre[3:] + WRIST_HALF_SPAN]
    return np.maximum(lower, settings.lower), np.minimum(upper, settings.upper)
