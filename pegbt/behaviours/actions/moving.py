"""Arm motions after the grasp: the transfer itself (lift, carry, lower onto the goal peg), rising
straight up, and parking an arm out of the camera's view.

Every motion that starts low among the pegs first rises straight up to the transfer height, so a tool
never sweeps sideways through pegs and blocks.
"""

from __future__ import annotations

from functools import partial

from pegbt.behaviours.base import MotionLeaf
from pegbt.behaviours.motion import CarryLeaf, above_pegs_first
from pegbt.behaviours.poses import tool_pose, transfer_for
from pegbt.motion.ik import solve_ik
from pegbt.motion.kinematics import forward_kinematics
from pegbt.motion.trajectory import Trajectory
from pegbt.motion.waypoints import TransferWaypoints


class Transfer(CarryLeaf):
    def waypoints(self) -> TransferWaypoints:
        return transfer_for(
            self.skills.cell,
            self.skills.motion,
            self.param("arm"),
            self.read("/board"),
            self.get("block"),
            self.get("grasp"),
            int(self.param("place")),
        )


class Rise(MotionLeaf):
    def begin(self) -> None:
        arm = self.param("arm")
        motion = self.motion(arm)
        start = motion.start_from(self.client(arm))
        target = forward_kinematics(start)
        target[:3, 3] += self.param("height") * self.skills.cell.up_in(arm)
        risen = solve_ik(target, motion.settings, what="risen")
        self.move(arm, partial(motion.through, start, [risen], ["risen"]), f"{arm} rising")


class Park(MotionLeaf):
    def begin(self) -> None:
        arm = self.param("arm")
        motion, cell = self.motion(arm), self.skills.cell
        start = motion.start_from(self.client(arm))
        home = tool_pose(motion.settings.home_tip, 0.0, cell.up_in(arm))
        joints = above_pegs_first(cell, self.skills.motion, arm, start, motion.settings)
        joints.append(solve_ik(home, motion.settings, what=f"{arm} home pose"))
        names = [f"stop {i}" for i in range(len(joints) - 1)] + ["home"]
        self.move(arm, partial(motion.through, start, joints, names), f"{arm} parking")

    def started(self, trajectories: list[Trajectory]) -> None:
        self.feedback_message = f"parking in {trajectories[0].duration:.2f} s"
