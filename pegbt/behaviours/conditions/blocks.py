"""Conditions on the blocks: whether later captures show a block on each peg it should be on
(`check_placed`), and whether a jaw still holds its block (`keep_holding`, read from the jaw's encoder:
a jaw that closes past `held_above` has lost its block)."""

from __future__ import annotations

from py_trees.common import Status

from pegbt.behaviours.base import RobotLeaf
from pegbt.behaviours.motion import SLIP_CHECK, ease_grip, slip
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
    """With `ease`, the jaw's squeeze eases as it starts to `grip_confirmed_below` under the wall, the grip
    the lift already carries a block with (a carry that eased it as it stopped leaves nothing to do): a jaw
    letting go later opens from there. A block slipping out then lets the jaw close towards that set-point:
    half of `grip_confirmed_below` under the wall shows it (`ease_grip`)."""

    def initialise(self) -> None:
        super().initialise()
        self.held_above = self.param("held_above")
        if self.param("ease"):
            self.held_above = ease_grip(self, self.param("arm"), self.held_above)

    def act(self) -> Status:
        arm = self.param("arm")
        slipped = slip(self.client(arm).jaw.measured_js.position[0], self.held_above)
        if slipped:
            return self.fail(f"the block slipped from {arm}'s jaw ({slipped}) while it waited")
        self.wake_at = self.context.clock.now() + SLIP_CHECK
        self.feedback_message = f"{arm} holds its block"
        return Status.RUNNING
