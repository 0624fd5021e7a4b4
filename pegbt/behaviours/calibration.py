"""Collecting calibration data on the executive: drive an arm through random set-points, record what it
was told and where it physically went (`fiducial_js`), in the dVRK dataset layout.

Like the reference recordings: a random walk of set-points over the joints peg transfer uses, each
reached by a rest-to-rest cubic, held `settle` seconds, then sampled. Commands go out uncompensated
(this is what a model learns from), so the leaf uses only the `robot` resource.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
from py_trees.common import Status

from pegbt.behaviours.base import arm_param
from pegbt.behaviours.robot import Robot
from pegbt.calibration.recording import RecordingWriter
from pegbt.errors import PegbtError
from pegbt.executive.leaf import Leaf
from pegbt.executive.params import Param
from pegbt.executive.registry import behaviour
from pegbt.motion.cubic import joint_move
from pegbt.motion.limits import arm_settings

# The random walk stays where peg transfer works: tool down over the board, wrist joints swept widely.
WALK_LOW = np.array([-0.5, -0.4, 0.10, -1.2, -1.2, -1.2])
WALK_HIGH = np.array([0.5, 0.4, 0.19, 1.2, 1.2, 1.2])
WALK_STEP = np.array([0.05, 0.05, 0.008, 0.3, 0.3, 0.3])  # standard deviation of one step per joint


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
        self.writer = RecordingWriter(Path(self.params["out"]), arm)
        self.q = np.clip(np.array(self.client.setpoint_js.position, dtype=float), WALK_LOW, WALK_HIGH)
        self.handle = None
        self.problem = ""
        self.wake_at = None
        self._next(first=True)

    def _next(self, first: bool = False) -> None:
        """Send the arm to the next set-point of the walk."""
        start = np.array(self.client.setpoint_js.position, dtype=float)
        if not first:
            self.q = np.clip(self.q + self.rng.normal(0.0, WALK_STEP), WALK_LOW, WALK_HIGH)
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
