"""Leaves that record a trial's transfers for its judge (`pegbt.behaviours.resources.trial`) and its progress bar.

They move nothing: `begin_transfer` notes which block goes where and when, `finish_transfer` the
executive's verdict. The tree decides what a verdict means for the rest of the trial.
"""

from __future__ import annotations

from py_trees.common import Status

from pegbt.behaviours.base import RobotLeaf


class BeginTransfer(RobotLeaf):
    def act(self) -> Status:
        record = self.robot.trial.begin(self.param("arms"), int(self.param("pick")), int(self.param("place")))
        self.put("transfer", record.index)
        self.feedback_message = f"transfer {record.index}: {record.arms} moves the block on peg {record.pick} to peg {record.place}"
        return Status.SUCCESS


class FinishTransfer(RobotLeaf):
    def act(self) -> Status:
        record = self.robot.trial.finish(int(self.get("transfer")), self.param("outcome"), self.param("note"))
        assert record.ended is not None  # `finish` stamps it
        self.feedback_message = (
            f"transfer {record.index} {record.outcome} after {record.ended - record.started:.2f} s"
        )
        return Status.SUCCESS
