"""Waiting for and checking what the other side of handover `n` said. A wait that runs out of `patience`
fails with the record as it stands, which is what the tick log and `pegbt log why` show."""

from __future__ import annotations

import math

from py_trees.common import Status

from pegbt.behaviours.leaves import AWAITS, CHECKS, WATCHES
from pegbt.behaviours.protocol_leaf import ProtocolLeaf, protocol_leaf
from pegbt.executive.leaf import Leaf
from pegbt.executive.registry import LeafSetup
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


LOOKS = (
    {name: protocol_leaf(name, _Await, condition=condition) for name, (condition, _) in AWAITS.items()}
    | {name: protocol_leaf(name, _Check, condition=condition) for name, (condition, _) in CHECKS.items()}
    | {name: protocol_leaf(name, _While, condition=condition) for name, (condition, _) in WATCHES.items()}
)


def look(setup: LeafSetup) -> Leaf:
    """The leaf that waits for, checks or watches the condition its declaration names."""
    return LOOKS[setup.spec.name](setup)
