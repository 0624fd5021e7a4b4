"""Planning one transfer: waypoints → IK → the paper's spline (Alg. 2) → SQP refinement → checked trajectory.

Also the paper's unoptimised baseline for the same waypoints: rest-to-rest cubics, stopping at each.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from pegbt.motion.checks import check_trajectory
from pegbt.motion.cubic import rest_to_rest_path
from pegbt.motion.ik import solve_ik
from pegbt.motion.limits import ArmSettings
from pegbt.motion.settings import MotionSettings, motion_settings
from pegbt.motion.spline import joint_direction, plan_spline
from pegbt.motion.sqp import SqpRefiner
from pegbt.motion.trajectory import HermitePath, Trajectory
from pegbt.motion.waypoints import WAYPOINT_NAMES, TransferWaypoints


@dataclass(frozen=True)
class TransferPlan:
    """A planned transfer: the streamable `trajectory`, the continuous `path` it was sampled from, the
    spline that warm-started it, the joint waypoints (4, 6), and whether the SQP refined the spline
    (False: the spline kept the channel on its own and is used as it is)."""

    trajectory: Trajectory
    path: HermitePath
    spline: HermitePath
    joints: NDArray[np.float64]
    refined: bool


def joint_waypoints(waypoints: TransferWaypoints, settings: ArmSettings) -> NDArray[np.float64]:
    """IK of the four transfer poses (4, 6); a `PegbtError` names the first unreachable one and why."""
    return np.stack(
        [solve_ik(pose, settings, what=f"transfer waypoint {i} ({name})") for i, (pose, name) in enumerate(zip(waypoints.poses, WAYPOINT_NAMES))]
    )


def cubic_transfer(waypoints: TransferWaypoints, settings: ArmSettings) -> Trajectory:
    """The paper's unoptimised transfer: a rest-to-rest cubic per segment, sampled at the control period."""
    path = rest_to_rest_path(joint_waypoints(waypoints, settings), settings, list(WAYPOINT_NAMES))
    return path.sample(settings.control_period)


class TransferPlanner:
    """Plans transfers for one arm; owns that arm's OSQP problem so consecutive plans reuse it."""

    def __init__(self, settings: ArmSettings, motion: MotionSettings | None = None) -> None:
        self.settings = settings
        self.refiner = SqpRefiner(settings, (motion or motion_settings()).sqp)

    def spline(self, waypoints: TransferWaypoints, joints: NDArray[np.float64] | None = None) -> HermitePath:
        """The paper's Alg. 2 spline through the waypoints (the SQP's warm start)."""
        q = joint_waypoints(waypoints, self.settings) if joints is None else joints
        up = waypoints.upright.axis
        return plan_spline(q, joint_direction(q[1], up), joint_direction(q[2], -up), self.settings)

    def plan(self, waypoints: TransferWaypoints) -> TransferPlan:
        """The refined, checked transfer; a `PegbtError` (and no trajectory) if the waypoints are out of
        reach or neither the refined path nor the spline passes the checks (limits, channels, upright
        tool, C1)."""
        joints = joint_waypoints(waypoints, self.settings)
        spline = self.spline(waypoints, joints)
        refined = self.refiner.refine(spline, waypoints.pick, waypoints.place, waypoints.upright)
        if refined is not None:  # its trajectory has passed the checks
            return TransferPlan(refined[1], refined[0], spline, joints, True)
        # If the SQP finds nothing, the spline itself may still keep the channel: the checks decide.
        trajectory = check_trajectory(
            spline.sample(self.settings.control_period),
            self.settings,
            leaving=waypoints.pick,
            arriving=waypoints.place,
            upright=waypoints.upright,
            what="transfer",
        )
        return TransferPlan(trajectory, spline, spline, joints, False)
