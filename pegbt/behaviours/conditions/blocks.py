"""Placing: open the jaw over the goal peg (the transfer already lowered the block onto it), and check
later captures for the block on its peg."""

from __future__ import annotations

from py_trees.common import Status

from pegbt.behaviours.base import RESOURCES, MotionLeaf, RobotLeaf, arm_param, key_param
from pegbt.executive.params import Param
from pegbt.executive.registry import behaviour
from pegbt.perception.blocks import block_on_peg
from pegbt.workcell import N_PEGS


@behaviour(
    "release",
    "open `arm`'s jaw, letting go of whatever it holds; writes `holding` false",
    params=(arm_param(), key_param("holding", "write", "whether the jaw holds a block (now false)")),
    resources=RESOURCES,
)
class Release(MotionLeaf):
    def begin(self) -> None:
        self.move_jaw(
            self.param("arm"), self.skills.motion.transfer.jaw_open, f"{self.param('arm')} jaw opening"
        )

    def done(self) -> Status:
        self.put("holding", False)
        return Status.SUCCESS


@behaviour(
    "check_placed",
    "succeed if the latest `/blocks` shows a trustworthy block on every peg in `pegs`",
    params=(
        Param(
            "pegs", list[int], "pegs that should each hold a block", choices=tuple(range(N_PEGS)), minimum=1
        ),
    ),
    reads=("/blocks",),
    resources=RESOURCES,
)
class CheckPlaced(RobotLeaf):
    def act(self) -> Status:
        blocks = self.read("/blocks")
        missing = []
        for peg in self.param("pegs"):
            block = block_on_peg(blocks, peg)
            if block is None or not block.ok:
                missing.append(f"peg {peg} ({'empty' if block is None else block.reason})")
        if missing:
            return self.fail(f"no block seen reliably on {', '.join(missing)}")
        self.feedback_message = f"a block on each of pegs {', '.join(map(str, self.param('pegs')))}"
        return Status.SUCCESS
