"""The handover protocol: what the giver and the receiver of one handover have said to each other.

Each handover of a trial has one record, `Handover`, kept on the blackboard under `key(n)`. Each side
says where it is by name (the giver: offered, arrived, withdrawn, released, given up; the receiver:
ready, closing, taken, refused) and waits for, or checks, what the other side said. The sides run as
parallel branches and never call each other; this module is the pure state they share, the leaves that
set and test it are in `pegbt.behaviours.actions.handover_protocol` and
`pegbt.behaviours.conditions.handover_protocol`. What to do when a step fails is the tree's.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, replace
from enum import StrEnum


class Giver(StrEnum):
    """What the giver said about one handover."""

    COMING = (
        "coming"  # its grasp chosen, the meeting planned, picking: the receiver may come to wait above it
    )
    OFFERED = "offered"  # picked, the meeting planned: the receiver may come to the meeting point
    ARRIVED = "arrived"  # holding the block out at the meeting point
    WITHDRAWN = "withdrawn"  # the block slipped: the giver fetches it again; the receiver keeps away
    RELEASED = "released"  # let go once the receiver held it
    GIVEN_UP = "given up"


class Receiver(StrEnum):
    """What the receiver said about one handover."""

    READY = "ready"  # done with the handover before: the giver may bring this block
    CLOSING = "closing"  # its jaw is closing on the block
    TAKEN = "taken"  # it holds the block
    REFUSED = "refused"  # it gave the handover up


@dataclass(frozen=True)
class Handover:
    """One handover's record: the number `n` in the trial and the last word of each side (None: nothing yet)."""

    n: int
    giver: Giver | None = None
    receiver: Receiver | None = None

    def said(self, word: Giver | Receiver) -> Handover:
        """This record after one side said `word`."""
        return replace(self, giver=word) if isinstance(word, Giver) else replace(self, receiver=word)

    def __str__(self) -> str:
        return (
            f"handover {self.n}: giver {self.giver or 'not offered yet'}, "
            f"receiver {self.receiver or 'not ready yet'}"
        )

    def __repr__(self) -> str:  # as tick logs and `log why` show it: the words, not the enum members
        return f"Handover({self.n}, giver={self.giver or 'none'}, receiver={self.receiver or 'none'})"


def key(n: int) -> str:
    """The blackboard key of handover `n`'s record."""
    return f"/handover/state_{n}"


def record_of(n: int, value: object) -> Handover:
    """Handover `n`'s record from what its key holds (nothing yet: an empty record)."""
    return value if isinstance(value, Handover) else Handover(n)


def _offered(record: Handover) -> bool:
    return record.giver in (Giver.COMING, Giver.OFFERED, Giver.ARRIVED)


# Named conditions on one record: what a side waits for or checks.
CONDITIONS: dict[str, Callable[[Handover], bool]] = {
    "ready": lambda record: record.receiver is not None,
    "taken": lambda record: record.receiver is Receiver.TAKEN,
    "not closing": lambda record: record.receiver is not Receiver.CLOSING,
    "not refused": lambda record: record.receiver is not Receiver.REFUSED,
    "offered": _offered,
    "offered or given up": lambda record: _offered(record) or record.giver is Giver.GIVEN_UP,
    "not given up": lambda record: record.giver is not Giver.GIVEN_UP,
    "withdrawn": lambda record: not _offered(record),
    "arrived": lambda record: record.giver is Giver.ARRIVED,
    "released": lambda record: record.giver is Giver.RELEASED,
}
