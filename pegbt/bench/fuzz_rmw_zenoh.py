"""The rmw_zenoh wire's campaign: attachments as they arrive on a sample (mutations of rmw_zenoh's int64
sequence number, int64 timestamp and 16-byte GID), and the names a node's liveliness tokens and keys are
built from (`--namespace`, the node name), declared on a zenoh session on loopback. An attachment decoded
from bytes that are not its encoding, or a name outside ROS 2's rules that reaches zenoh, counts as
`absurd_accepted`."""

from __future__ import annotations

import random
from pathlib import Path

from pegbt.bench.fuzzing import SILENT, Tally

NAMES = ("", "/", "lab2", "/lab2/", "/lab2/dvrk", "a_1/b_2")
ODD_NAMES = (
    "*",
    "**",
    "lab/*",
    "$*",
    "a#b",
    "a?b",
    "a//b",
    "lab-2",
    "läb",
    "a b",
    "%",
    "a" * 300,
    "\x00",
)


def _attachment(rng: random.Random) -> tuple[bytes, str]:
    from pegbt.transport.rmw_zenoh import encode_attachment

    valid = encode_attachment(
        rng.randrange(2**63), rng.randrange(2**63), bytes(rng.randrange(256) for _ in range(16))
    )
    raw = bytearray(valid)
    kind = rng.choice(["flip", "truncate", "extend", "random", "gid length", "whole"])
    if kind == "flip":
        for _ in range(rng.randint(1, 4)):
            raw[rng.randrange(len(raw))] ^= 1 << rng.randrange(8)
    elif kind == "truncate":
        raw = raw[: rng.randrange(len(raw))]
    elif kind == "extend":
        raw += bytes(rng.randrange(256) for _ in range(rng.randint(1, 64)))
    elif kind == "random":
        raw = bytearray(rng.randrange(256) for _ in range(rng.randint(0, 80)))
    elif kind == "gid length":
        raw = bytearray(encode_attachment(1, 2, bytes(rng.choice([0, 8, 15, 17, 4096]))))
    return bytes(raw), kind


def _name(rng: random.Random) -> tuple[str, bool]:
    """A namespace or node name, and whether it breaks ROS 2's rules."""
    if rng.random() < 0.5:
        return rng.choice(NAMES), False
    base = rng.choice(NAMES[2:])
    if rng.random() < 0.1:  # a token starting with a digit
        return "/1" + base.lstrip("/"), True
    odd = rng.choice(ODD_NAMES)  # each breaks the rules wherever it is put
    at = rng.randrange(len(base) + 1)
    return base[:at] + odd + base[at:], True


def fuzz_rmw_zenoh(count: int, rng: random.Random, work: Path) -> Tally:
    from pegbt.transport.dvrk_topics import PsmTopics
    from pegbt.transport.rmw_zenoh import decode_attachment, encode_attachment
    from pegbt.transport.session import SessionSettings, open_session
    from pegbt.transport.wires import make_wire

    tally = Tally()
    session = open_session(SessionSettings())
    topic = PsmTopics("PSM1").measured_js
    try:
        for n in range(count):
            if rng.random() < 0.5:
                payload, kind = _attachment(rng)

                def decode(payload: bytes = payload) -> object:
                    decoded = decode_attachment(payload)
                    if decoded is None:
                        return False
                    again = encode_attachment(
                        decoded.sequence_number, decoded.source_timestamp_ns, decoded.gid
                    )
                    return True if again == payload else SILENT

                tally.record(decode, parsed=kind == "whole", absurd=False, what=f"attachment: {kind}")
                continue
            namespace, odd_namespace = _name(rng)
            node, odd_node = _name(rng) if rng.random() < 0.3 else ("pegbt_fuzz", False)
            node = node.strip("/") or "pegbt_fuzz" if not odd_node else node

            def declare(namespace: str = namespace, node: str = node) -> bool:
                wire = make_wire("rmw_zenoh", session, namespace, node)
                try:
                    wire.publisher(topic)
                    wire.subscriber(topic, lambda payload: None)
                finally:
                    wire.close()
                return True

            tally.record(
                declare,
                parsed=not (odd_namespace or odd_node),
                absurd=odd_namespace or odd_node,
                what=f"namespace {namespace[:40]!r}, node {node[:40]!r}",
            )
    finally:
        session.close()
    return tally
