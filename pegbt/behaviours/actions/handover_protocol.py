"""The handover protocol's words: each side says where it is in handover `n` by name (offered, held out,
withdrawn, ...), which the other side waits for or checks (`conditions/handover_protocol.py`)."""

from __future__ import annotations

from py_trees.common import Status

from pegbt.behaviours.protocol_leaf import ProtocolLeaf, handover_number, register_protocol_leaf
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
    register_protocol_leaf(_name, _doc + "; succeeds", _Say, (handover_number("write"),), word=_word)
