"""Leaves that speak the handover protocol (`pegbt.handover_protocol`): each side says where it is by name,
waits for what the other side said, or checks it. They move no arm; the arm leaves are `handover.py`'s.

Every leaf takes the handover's number `n` and reads or writes that handover's record only, so a side
never mistakes a handover the other gave up on for the next one. A wait that runs out of `patience` fails
with the record as it stands, which is what the tick log and `pegbt log why` show.
"""

from __future__ import annotations

import math
from typing import Literal

from py_trees.common import Status

from pegbt.executive.leaf import Leaf
from pegbt.executive.params import MAX_COUNT, MAX_SECONDS, Param
from pegbt.executive.registry import LeafSetup, behaviour
from pegbt.handover_protocol import CONDITIONS, Giver, Handover, Receiver, key, record_of


def _number(access: Literal["read", "write"]) -> Param:
    return Param(
        "n",
        int,
        "the handover's number in the trial",
        minimum=1,
        maximum=MAX_COUNT,
        key=access,
        names_key=key,
    )


_PATIENCE = Param(
    "patience",
    float,
    "seconds to wait before failing (none: until halted)",
    default=None,
    minimum=0.0,
    maximum=MAX_SECONDS,
)


class _ProtocolLeaf(Leaf):
    def record(self) -> Handover:
        n = self.params["n"]
        try:
            value = self.read(key(n))
        except KeyError:
            value = None
        return record_of(n, value)

    def shown(self, record: Handover) -> str:
        return f"{key(record.n)}: {record}"


class _Say(_ProtocolLeaf):
    """Writes one side's word into the record; a word already said writes nothing (no tick is woken)."""

    word: Giver | Receiver

    def update(self) -> Status:
        record = self.record()
        said = record.said(self.word)
        if said != record:
            self.write(key(record.n), said)
        self.feedback_message = self.shown(said)
        return Status.SUCCESS


class _Await(_ProtocolLeaf):
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


class _Check(_ProtocolLeaf):
    """Succeeds if the condition holds now, fails if not: it steers the tree (an echo for `log why`)."""

    condition: str

    def update(self) -> Status:
        record = self.record()
        holds = CONDITIONS[self.condition](record)
        self.feedback_message = f"{'' if holds else 'not: '}{self.condition} ({self.shown(record)})"
        return Status.SUCCESS if holds else Status.FAILURE


class _While(_ProtocolLeaf):
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


def _register(
    name: str, doc: str, base: type[_ProtocolLeaf], params: tuple[Param, ...], **fixed: object
) -> None:
    cls = type(name, (base,), dict(fixed))

    def factory(setup: LeafSetup) -> Leaf:
        return cls(setup)

    behaviour(name, doc, params=params)(factory)


for _name, _word, _doc in (
    (
        "offer",
        Giver.OFFERED,
        "the giver offers handover `n`: picked, the meeting planned; the receiver may come",
    ),
    ("hold_out", Giver.ARRIVED, "the giver says it holds the block out at the meeting point"),
    ("withdraw", Giver.WITHDRAWN, "the giver withdraws its offer: the block slipped, it fetches it again"),
    ("hand_over", Giver.RELEASED, "the giver says it let go of the block the receiver took"),
    ("give_up", Giver.GIVEN_UP, "the giver gives handover `n` up"),
    ("ready_for", Receiver.READY, "the receiver is ready for handover `n` (done with the one before)"),
    ("close_on", Receiver.CLOSING, "the receiver's jaw closes on the block"),
    ("back_off", Receiver.READY, "the receiver backs off: its jaw no longer closes on the block"),
    ("take", Receiver.TAKEN, "the receiver says it holds the block"),
    ("refuse", Receiver.REFUSED, "the receiver gives handover `n` up"),
):
    _register(_name, _doc + "; succeeds", _Say, (_number("write"),), word=_word)

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
    _register(_name, _doc, _Await, (_number("read"), _PATIENCE), condition=_condition)

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
    _register(_name, _doc, _Check, (_number("read"),), condition=_condition)

# The leaves that only steer the tree: their failure echoes the other side's, never a cause of its own.
STEERING = frozenset({*CHECKS, "unless_refused"})

_register(
    "unless_refused",
    "run while the receiver has not refused handover `n`; fail when it does",
    _While,
    (_number("read"),),
    condition="not refused",
)
