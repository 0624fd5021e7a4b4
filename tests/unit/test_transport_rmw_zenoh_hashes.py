"""pegbt's rmw_zenoh type hashes and attachments are the ones zenoh-ros2-sdk (ROBOTIS's rmw_zenoh client)
computes and decodes."""

from __future__ import annotations

from zenoh_ros2_sdk.attachment import Attachment as SdkAttachment

from pegbt.transport.codec import JOINT_STATE
from pegbt.transport.rmw_zenoh import decode_attachment, encode_attachment, type_hash


def test_type_hashes_and_attachment_match_rmw_zenoh() -> None:
    assert type_hash(JOINT_STATE).startswith("RIHS01_a13ee3a330e346c9d87b5aa18d24e116")
    raw = encode_attachment(7, 1_700_000_000_123_456_789, bytes(range(16)))
    theirs = SdkAttachment.from_bytes(raw)
    assert (theirs.sequence_id, theirs.timestamp_ns, theirs.gid) == (
        7,
        1_700_000_000_123_456_789,
        bytes(range(16)),
    )
    ours = decode_attachment(SdkAttachment(8, 5, bytes(16)).to_bytes())
    assert ours is not None and (ours.sequence_number, ours.source_timestamp_ns) == (8, 5)
    assert decode_attachment(b"PSM1/servo_jp#12") is None
    assert decode_attachment(None) is None
