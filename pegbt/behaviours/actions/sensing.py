"""Sensing: capture a point cloud, register the pegboard (once per trial), find the blocks.

The capture is asynchronous: requested in `initialise`, collected by a later tick. Registration and
block search run on the cloud on the blackboard, off the tick (on a worker thread: Open3D's ICP and
DBSCAN take a few hundred milliseconds); their results go back to the blackboard (`/board`, `/blocks`)
with a summary as feedback, so a tick log shows what was seen. In lockstep (the run's work inline) they run
Open3D on one thread: a seed then gives the same poses, and so the same trial, in any process (a campaign
on a Dask cluster equals the local one seed for seed).
"""

from __future__ import annotations

import time

from numpy.typing import ArrayLike
from py_trees.common import Status

from pegbt.behaviours.base import ComputeLeaf, RobotLeaf
from pegbt.perception.blocks import BlockEstimate
from pegbt.perception.board import BoardEstimate
from pegbt.perception.cloud import open3d_threads


class Capture(RobotLeaf):
    def initialise(self) -> None:
        self.handle = self.robot.camera.capture_async()
        self.deadline = time.monotonic() + self.robot.camera.timeout
        self.feedback_message = "capturing"

    def act(self) -> Status:
        if not self.handle.ready:  # sends the trigger once a camera listens
            if time.monotonic() > self.deadline:
                if not self.handle.sent:
                    self.handle.result(
                        0.0
                    )  # EndpointSilent: no camera to ask, the endpoint is gone (the run halts)
                return self.fail(
                    f"no point cloud within {self.robot.camera.timeout:g} s of the capture request"
                )
            return Status.RUNNING
        points = self.handle.points
        self.write("/cloud", points)
        self.feedback_message = f"{len(points)} points"
        return Status.SUCCESS


class RegisterBoard(ComputeLeaf):
    def inputs(self) -> tuple:
        return (self.read("/cloud"),)

    def compute(self, cloud: ArrayLike) -> BoardEstimate:
        with open3d_threads(1 if self.context.work.inline else None):
            return self.skills.registration.fit(cloud)

    def finish(self, board: BoardEstimate) -> Status:
        if not board.ok:
            return self.fail(f"pegboard registration failed: {board.reason}")
        self.write("/board", board)
        self.write("/board_registered", True)
        self.feedback_message = (
            f"board registered: fitness {board.fitness:.2f}, RMSE {board.rmse * 1000:.2f} mm"
        )
        return Status.SUCCESS


class FindBlocks(ComputeLeaf):
    def inputs(self) -> tuple:
        return self.read("/cloud"), self.read("/board")

    def compute(self, cloud: ArrayLike, board: BoardEstimate) -> list[BlockEstimate]:
        with open3d_threads(1 if self.context.work.inline else None):
            return self.skills.locator.locate(cloud, board)

    def finish(self, blocks: list[BlockEstimate]) -> Status:
        self.write("/blocks", blocks)
        where = ", ".join("board" if block.peg is None else str(block.peg) for block in blocks if block.ok)
        doubtful = [block.reason for block in blocks if not block.ok]
        self.feedback_message = f"{len(blocks)} block(s); trustworthy on pegs: {where or 'none'}" + (
            f"; doubtful: {'; '.join(doubtful)}" if doubtful else ""
        )
        if not any(block.ok for block in blocks):
            return self.fail(f"a poor capture: {self.feedback_message}")
        return Status.SUCCESS
