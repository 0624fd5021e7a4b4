"""What every leaf of the handover protocol shares (`pegbt.handover_protocol`): the handover's number `n`,
whose record alone a leaf reads or writes (so a side never mistakes a handover the other gave up on for the
next one), a wait's `patience`, and how a leaf shows the record in the tick log and `pegbt log why`. The
leaves are in `actions/handover_protocol.py` (a side says where it is) and `conditions/handover_protocol.py`
(it waits for or checks what the other side said); they move no arm.
"""

from __future__ import annotations

from typing import Literal

from pegbt.executive.leaf import Leaf
from pegbt.executive.params import MAX_COUNT, MAX_SECONDS, Param
from pegbt.executive.registry import LeafSetup, behaviour
from pegbt.handover_protocol import Handover, key, record_of


def handover_number(access: Literal["read", "write"]) -> Param:
    """The parameter `n`: the handover's number, naming the one record the leaf reads or writes."""
    return Param(
        "n",
        int,
        "the handover's number in the trial",
        minimum=1,
        maximum=MAX_COUNT,
        key=access,
        names_key=key,
    )


PATIENCE = Param(
    "patience",
    float,
    "seconds to wait before failing (none: until halted)",
    default=None,
    minimum=0.0,
    maximum=MAX_SECONDS,
)


class ProtocolLeaf(Leaf):
    """A leaf on one handover's record, `n`."""

    def record(self) -> Handover:
        n = self.params["n"]
        try:
            value = self.read(key(n))
        except KeyError:
            value = None
        return record_of(n, value)

    def shown(self, record: Handover) -> str:
        return f"{key(record.n)}: {record}"


def register_protocol_leaf(
    name: str, doc: str, base: type[ProtocolLeaf], params: tuple[Param, ...], **fixed: object
) -> None:
    """Registers leaf `name` as a subclass of `base` with `fixed` class attributes (its word or condition)."""
    cls = type(name, (base,), dict(fixed))

    def factory(setup: LeafSetup) -> Leaf:
        return cls(setup)

    factory.__module__ = cls.__module__ = base.__module__  # the leaf belongs where its kind is defined
    behaviour(name, doc, params=params)(factory)
