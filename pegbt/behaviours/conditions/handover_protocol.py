"""Waiting for and checking what the other side of handover `n` said. A wait that runs out of `patience`
fails with the record as it stands, which is what the tick log and `pegbt log why` show."""

from __future__ import annotations

import math

from py_trees.common import Status

from pegbt.behaviours.protocol_leaf import PATIENCE, ProtocolLeaf, handover_number, register_protocol_leaf
from pegbt.handover_protocol import CONDITIONS


class _Await(ProtocolLeaf):
    """Running until the condition holds; fails once `patience` has run out (a timeout's semantics)."""

    condition: str

    def initialise(self) -> None:
        patience = self.params["patience"]
        self.deadline = math.inf if patience is None else self.context.clock.now() + patience
        self.wake_at = self.deadline  # only the other side (or the deadline) can end the wait

    def update(self) -> Status:
        record = self.record()
        if CONDITIONS[self.condition](record):
            self.feedback_message = f"{self.condition} ({self.shown(record)})"
            return Status.SUCCESS
        if self.context.clock.now() - self.deadline > 0:
            self.feedback_message = (
                f"not {self.condition} after {self.params['patience']:g} s ({self.shown(record)})"
            )
            return Status.FAILURE
        self.feedback_message = f"waiting until {self.condition} ({self.shown(record)})"
        return Status.RUNNING


class _Check(ProtocolLeaf):
    """Succeeds if the condition holds now, fails if not: it steers the tree (an echo for `log why`)."""

    condition: str

    def update(self) -> Status:
        record = self.record()
        holds = CONDITIONS[self.condition](record)
        self.feedback_message = f"{'' if holds else 'not: '}{self.condition} ({self.shown(record)})"
        return Status.SUCCESS if holds else Status.FAILURE


class _While(ProtocolLeaf):
    """Running while the condition holds, failing when it stops holding: a watch beside a wait in a parallel."""

    condition: str

    def initialise(self) -> None:
        self.wake_at = math.inf

    def update(self) -> Status:
        record = self.record()
        if CONDITIONS[self.condition](record):
            self.feedback_message = f"{self.condition} ({self.shown(record)})"
            return Status.RUNNING
        self.feedback_message = f"no longer {self.condition} ({self.shown(record)})"
        return Status.FAILURE


for _name, _condition, _doc in (
    ("await_ready", "ready", "the giver waits until the receiver is ready for handover `n`"),
    ("await_taker", "taken", "the giver waits until the receiver holds the block"),
    ("await_closed", "not closing", "the giver waits until the receiver's jaw is not closing on the block"),
    (
        "await_offer",
        "offered or given up",
        "the receiver waits until the giver offers the block or gives it up",
    ),
    (
        "await_arrival",
        "arrived",
        "the receiver waits until the giver holds the block out at the meeting point",
    ),
    ("await_release", "released", "the receiver waits until the giver let go"),
):
    register_protocol_leaf(_name, _doc, _Await, (handover_number("read"), PATIENCE), condition=_condition)

CHECKS = {
    "is_taken": ("taken", "whether the receiver holds the block"),
    "receiver_waits": (
        "not refused",
        "whether the receiver still waits for handover `n` (has not refused it)",
    ),
    "not_given_up": ("not given up", "whether the giver still gives handover `n` (has not given it up)"),
    "is_offered": ("offered", "whether the giver offers the block (offered or holding it out)"),
    "is_withdrawn": ("withdrawn", "whether the giver's offer is withdrawn (or was never made, or given up)"),
    "is_held_out": ("arrived", "whether the giver holds the block out at the meeting point"),
}
for _name, (_condition, _doc) in CHECKS.items():
    register_protocol_leaf(_name, _doc, _Check, (handover_number("read"),), condition=_condition)

# The leaves that only steer the tree: their failure echoes the other side's, never a cause of its own.
STEERING = frozenset({*CHECKS, "unless_refused"})

register_protocol_leaf(
    "unless_refused",
    "run while the receiver has not refused handover `n`; fail when it does",
    _While,
    (handover_number("read"),),
    condition="not refused",
)
