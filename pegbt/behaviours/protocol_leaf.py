"""What every leaf of the handover protocol shares (`pegbt.handover_protocol`): the handover's number `n`,
whose record alone a leaf reads or writes (so a side never mistakes a handover the other gave up on for the
next one), and how a leaf shows the record in the tick log and `pegbt log why` (`n` and a wait's
`patience` are declared in `pegbt.behaviours.params`, the leaves' names in `pegbt.behaviours.leaves`).
The leaves are in `actions/handover_protocol.py` (a side says where it is) and
`conditions/handover_protocol.py` (it waits for or checks what the other side said); they move no arm.
"""

from __future__ import annotations

from pegbt.executive.leaf import Leaf
from pegbt.handover_protocol import Handover, key, record_of


class ProtocolLeaf(Leaf):
    """A leaf on one handover's record, `n`."""

    def record(self) -> Handover:
        return read_record(self, self.params["n"])

    def shown(self, record: Handover) -> str:
        return f"{key(record.n)}: {record}"


def read_record(leaf: Leaf, n: int) -> Handover:
    """Handover `n`'s record as `leaf` reads it (empty before either side said anything)."""
    try:
        value = leaf.read(key(n))
    except KeyError:
        value = None
    return record_of(n, value)


def protocol_leaf(name: str, base: type[ProtocolLeaf], **fixed: object) -> type[ProtocolLeaf]:
    """Leaf `name` as a subclass of `base` with `fixed` class attributes (its word or condition)."""
    cls = type(name, (base,), dict(fixed))
    cls.__module__ = base.__module__  # the leaf belongs where its kind is defined
    return cls
