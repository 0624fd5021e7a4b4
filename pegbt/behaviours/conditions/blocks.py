"""Conditions on the blocks: whether later captures show a block on each peg it should be on
(`check_placed`), and whether a jaw still holds its block (`keep_holding`, read from the jaw's encoder:
a jaw that closes past `held_above` has lost its block)."""

from __future__ import annotations

from py_trees.common import Status

from pegbt.behaviours.base import RobotLeaf
from pegbt.behaviours.motion import SLIP_CHECK, slip
from pegbt.perception.blocks import block_on_peg


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


class KeepHolding(RobotLeaf):
    def act(self) -> Status:
        arm = self.param("arm")
        slipped = slip(self.client(arm).jaw.measured_js.position[0], self.param("held_above"))
        if slipped:
            return self.fail(f"the block slipped from {arm}'s jaw ({slipped}) while it waited")
        self.wake_at = self.context.clock.now() + SLIP_CHECK
        self.feedback_message = f"{arm} holds its block"
        return Status.RUNNING
