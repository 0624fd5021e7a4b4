"""Collecting calibration data on the executive: `pegbt.calibration.collect`'s recording, one tick at a time.

The set-points are the calibration package's, over `task_box` (the joints peg transfer uses): a random
smooth path for a model to learn from, or spread over every joint's range for a refit (`DESIGNS`); each reached along a straight joint-space line, held `settle` seconds and sampled:
set-point against physical joints (`fiducial_js`). Commands go out uncompensated (this is what a model
learns from), so the leaf uses only the `robot` resource.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
from py_trees.common import Status

from pegbt.behaviours.resources.robot import Robot
from pegbt.calibration.collect import DESIGNS, straight_move
from pegbt.calibration.task import task_box
from pegbt.errors import PegbtError
from pegbt.executive.leaf import Leaf
from pegbt.physics.recording import RecordingWriter
from pegbt.transport.arm import MotionHandle
from pegbt.transport.crtk_arm import RobotMove
from pegbt.transport.streaming import StreamedMotion


class CollectCalibration(Leaf):
    handle: MotionHandle | RobotMove | StreamedMotion | None

    def setup(self, **kwargs: object) -> None:
        self.robot = self.context.resource("robot", Robot)

    def initialise(self) -> None:
        self.client = self.robot.arm(self.param("arm"))
        self.setpoints = DESIGNS[self.param("design")](
            *task_box(self.client.name), self.param("samples"), np.random.default_rng(self.param("seed"))
        )
        # a recording of as many set-points as asked: the command that asks knows what its use needs
        self.writer = RecordingWriter(Path(self.param("out")), self.client.name, self.param("samples"))
        self.handle = None
        self.problem = ""
        self._next()

    def _next(self) -> None:
        """Send the arm to the next set-point; it is sampled `settle` s after the move's end."""
        goal = self.setpoints[len(self.writer)]
        move = straight_move(self.client.setpoint_js.position, goal, self.client.settings)
        try:
            self.handle = self.client.move_jp(move)
        except PegbtError as error:
            self.problem = str(error)
        self.sample_at = self.context.clock.now() + float(move.t[-1]) + self.params["settle"]
        self.wake_at = self.sample_at

    def update(self) -> Status:
        if self.problem:
            self.feedback_message = self.problem
            return Status.FAILURE
        now = self.context.clock.now()
        assert self.handle is not None  # `_next` set it, or the problem above
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
        if len(self.writer) < len(self.setpoints):
            self._next()
            self.feedback_message = f"{len(self.writer)} of {len(self.setpoints)} set-points"
            return Status.RUNNING
        self.feedback_message = f"wrote {self.writer.close()} ({len(self.setpoints)} set-points)"
        return Status.SUCCESS

    def terminate(self, new_status: Status) -> None:
        if new_status == Status.INVALID and self.handle is not None:
            try:
                self.handle.stop()
            except PegbtError:
                pass  # the endpoint is gone: nothing moves
