"""Collecting calibration data on the executive: drive an arm through random set-points, record what it
was told and where it physically went (`fiducial_js`), in the dVRK dataset layout.

Like the reference recordings: a random walk of set-points over the joints peg transfer uses (over
every peg, grasp to transfer height, the grasp yaw window), each reached by a rest-to-rest cubic, held
`settle` seconds, then sampled. Commands go out uncompensated
(this is what a model learns from), so the leaf uses only the `robot` resource.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
from numpy.typing import NDArray
from py_trees.common import Status

from pegbt.behaviours.base import arm_param
from pegbt.behaviours.poses import to_arm, tool_pose, up_in_arm
from pegbt.behaviours.robot import Robot
from pegbt.calibration.recording import RecordingWriter
from pegbt.errors import PegbtError
from pegbt.executive.leaf import Leaf
from pegbt.executive.params import Param
from pegbt.executive.registry import behaviour
from pegbt.motion.cubic import joint_move
from pegbt.motion.ik import inverse_kinematics
from pegbt.motion.limits import arm_settings
from pegbt.motion.settings import motion_settings
from pegbt.workcell import workcell

WALK_STEP = np.array([0.05, 0.05, 0.008, 0.3, 0.3, 0.3])  # standard deviation of one step per joint
WALK_MARGIN = np.array([0.1, 0.1, 0.01, 0.3, 0.3, 0.3])  # beyond the task's joints on each side
TASK_YAWS = np.radians(np.linspace(-70.0, 70.0, 8))  # gripper yaws of the grasp window


def task_joint_box(arm: str) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """The joints `arm` uses in peg transfer (tool down over every peg, from the grasp height to above the
    transfer height, across the grasp yaw window), widened by `WALK_MARGIN`, within the joint limits: a
    model learns the cable effects where it will compensate them."""
    cell, heights, settings = workcell(), motion_settings().transfer, arm_settings(arm)
    up = up_in_arm(cell, arm)
    levels = (-heights.block_top_below_peg_top - heights.grasp_depth, heights.transfer_height_above_peg_top + 0.02)
    poses = [tool_pose(to_arm(cell, arm, top) + level * up, yaw, up)
             for top in cell.pegs.tops for level in levels for yaw in TASK_YAWS]
    solution = inverse_kinematics(np.array(poses), settings)
    q = solution.q[solution.ok]
    return np.maximum(q.min(axis=0) - WALK_MARGIN, settings.lower), np.minimum(q.max(axis=0) + WALK_MARGIN, settings.upper)


@behaviour(
    "collect_calibration",
    "drive `arm` through `samples` random set-points (uncompensated), hold each `settle` s, and record "
    "commanded and physical joints to the recording folder `out`",
    params=(
        arm_param(),
        Param("samples", int, "set-points to record", minimum=1),
        Param("settle", float, "seconds to hold each set-point before sampling it", default=0.3, minimum=0.0),
        Param("out", str, "recording folder to write (relative to the working directory)"),
        Param("seed", int, "seed of the random walk", default=0),
    ),
    resources=("robot",),
)
class CollectCalibration(Leaf):
    def setup(self, **kwargs: object) -> None:
        self.robot = self.context.resource("robot", Robot)

    def initialise(self) -> None:
        arm = self.params["arm"]
        self.client = self.robot.arm(arm)
        self.settings = arm_settings(arm)
        self.rng = np.random.default_rng(self.params["seed"])
        self.low, self.high = task_joint_box(arm)
        self.writer = RecordingWriter(Path(self.params["out"]), arm)
        self.q = (self.low + self.high) / 2
        self.handle = None
        self.problem = ""
        self.wake_at = None
        self._next(first=True)

    def _next(self, first: bool = False) -> None:
        """Send the arm to the next set-point of the walk."""
        start = np.array(self.client.setpoint_js.position, dtype=float)
        if not first:
            self.q = np.clip(self.q + self.rng.normal(0.0, WALK_STEP), self.low, self.high)
        trajectory = joint_move(start, self.q, self.settings)
        try:
            self.handle = self.client.move_jp(trajectory)
        except PegbtError as error:
            self.problem = str(error)
        self.sample_at = self.context.clock.now() + trajectory.duration + self.params["settle"]

    def update(self) -> Status:
        if self.problem:
            self.feedback_message = self.problem
            return Status.FAILURE
        now = self.context.clock.now()
        try:
            if self.handle.failed:
                self.feedback_message = f"set-point {len(self.writer)}: {self.handle.error}"
                return Status.FAILURE
            if self.handle.busy or now < self.sample_at:
                self.wake_at = self.sample_at if now < self.sample_at else None
                return Status.RUNNING
            self.writer.add(self.client.setpoint_js.position, self.client.fiducial_js.position, now)
        except PegbtError as error:
            self.feedback_message = str(error)
            return Status.FAILURE
        if len(self.writer) < self.params["samples"]:
            self._next()
            self.wake_at = self.sample_at
            self.feedback_message = f"{len(self.writer)} of {self.params['samples']} set-points"
            return Status.RUNNING
        self.feedback_message = f"wrote {self.writer.close()} ({self.params['samples']} set-points)"
        return Status.SUCCESS

    def terminate(self, new_status: Status) -> None:
        if new_status == Status.INVALID and self.handle is not None:
            try:
                self.handle.stop()
            except PegbtError:
                pass  # the endpoint is gone: nothing moves
