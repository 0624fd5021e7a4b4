"""The handover protocol's words: each side says where it is in handover `n` by name (offered, held out,
withdrawn, ...), which the other side waits for or checks (`conditions/handover_protocol.py`)."""

from __future__ import annotations

from py_trees.common import Status

from pegbt.behaviours.leaves import SAYINGS
from pegbt.behaviours.protocol_leaf import ProtocolLeaf, protocol_leaf
from pegbt.executive.leaf import Leaf
from pegbt.executive.registry import LeafSetup
from pegbt.handover_protocol import Giver, Receiver, key


class _Say(ProtocolLeaf):
    """Writes one side's word into the record; a word already said writes nothing (no tick is woken)."""

    word: Giver | Receiver

    def update(self) -> Status:
        record = self.record()
        said = record.said(self.word)
        if said != record:
            self.write(key(record.n), said)
        self.feedback_message = self.shown(said)
        return Status.SUCCESS


SAYS = {name: protocol_leaf(name, _Say, word=word) for name, (word, _) in SAYINGS.items()}


def say(setup: LeafSetup) -> Leaf:
    """The leaf that says the word its declaration names (`SAYINGS`)."""
    return SAYS[setup.spec.name](setup)
