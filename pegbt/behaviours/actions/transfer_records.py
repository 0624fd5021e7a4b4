"""Leaves that record a trial's transfers for its judge (`pegbt.behaviours.resources.trial`) and its progress bar.

They move nothing: `begin_transfer` notes which block goes where and when, `finish_transfer` the
executive's verdict. The tree decides what a verdict means for the rest of the trial.
"""

from __future__ import annotations

from py_trees.common import Status

from pegbt.behaviours.base import RobotLeaf, key_param, peg_param
from pegbt.executive.params import Param
from pegbt.executive.registry import behaviour


@behaviour(
    "begin_transfer",
    "record the start of a transfer from peg `pick` to peg `place` by `arms`; writes its number to `transfer`",
    params=(
        Param("arms", str, "the arm, or giver→receiver for a handover"),
        peg_param("pick", "start peg"),
        peg_param("place", "goal peg"),
        key_param("transfer", "write", "the transfer's number"),
    ),
    resources=("robot", "skills"),
)
class BeginTransfer(RobotLeaf):
    def act(self) -> Status:
        record = self.robot.trial.begin(self.param("arms"), int(self.param("pick")), int(self.param("place")))
        self.put("transfer", record.index)
        self.feedback_message = f"transfer {record.index}: {record.arms} moves the block on peg {record.pick} to peg {record.place}"
        return Status.SUCCESS


@behaviour(
    "finish_transfer",
    "record how transfer `transfer` ended, as the executive believes (placed, skipped or failed); succeeds",
    params=(
        Param("outcome", str, "the verdict", choices=("placed", "skipped", "failed")),
        Param("note", str, "why, for the result table", default=""),
        key_param("transfer", "read", "the transfer's number"),
    ),
    resources=("robot", "skills"),
)
class FinishTransfer(RobotLeaf):
    def act(self) -> Status:
        record = self.robot.trial.finish(int(self.get("transfer")), self.param("outcome"), self.param("note"))
        assert record.ended is not None  # `finish` stamps it
        self.feedback_message = (
            f"transfer {record.index} {record.outcome} after {record.ended - record.started:.2f} s"
        )
        return Status.SUCCESS
