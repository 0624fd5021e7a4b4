"""Tagged messages: who sent each one, its number on its key, and which command it answers.

Zenoh delivers the messages of one key in order, but not messages of different keys relative to each
other. So every message carries a small tag as a zenoh attachment (invisible to a ROS 2 bridge):
`source|seq|cause|outcome`. Counting per key lets a lockstep clock wait until everything sent before a
step has arrived (a barrier), and `cause`/`outcome` let a motion handle know exactly when *its* command
was accepted, refused, finished or aborted.
"""

from __future__ import annotations

import json
import logging
import threading
import time
import uuid
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from typing import Any, Generic, TypeVar

import zenoh

from pegbt.errors import PegbtError

T = TypeVar("T")
LOG = logging.getLogger("pegbt.transport")
MAX_SEQ_DIGITS = 19  # a sequence number fits a signed 64-bit integer
MAX_TAG_BYTES = 512


class BadTag(PegbtError):
    """An attachment that is there but is not a tag: refused, counted and logged, never a silent failure
    of the zenoh callback (a `²` or 5,000 digits where the number belongs made `int()` raise in it)."""


@dataclass(frozen=True)
class Tag:
    """The attachment of one message."""

    source: str
    seq: int
    cause: str = ""  # id of the command this message reports on (a hold's: the motion it stops)
    outcome: str = ""  # accepted, refused, done or aborted

    def command_id(self, key: str) -> str:
        """The id of the command this message carries on `key` (sequence numbers count per key)."""
        return f"{self.source}:{key}:{self.seq}"

    def encode(self) -> bytes:
        return f"{self.source}|{self.seq}|{self.cause}|{self.outcome}".encode()

    @classmethod
    def decode(cls, raw: zenoh.ZBytes | bytes | None) -> Tag | None:
        """The tag of an attachment, or None for untagged messages and foreign attachments (a ROS 2 bridge,
        rmw_zenoh's own); `BadTag` for one shaped as a tag (four `|` fields) whose number is not 1 to 19
        ASCII digits, or that is longer than any tag."""
        if raw is None:
            return None
        data = raw.to_bytes() if isinstance(raw, zenoh.ZBytes) else raw
        parts = data.decode(errors="replace").split("|")
        if len(parts) != 4:
            return None
        number = parts[1]
        if len(data) > MAX_TAG_BYTES:
            raise BadTag(f"a tag of {len(data)} bytes; tags are at most {MAX_TAG_BYTES}", field="attachment")
        if not (number.isascii() and number.isdigit() and 0 < len(number) <= MAX_SEQ_DIGITS):
            raise BadTag(
                f"sequence number {number[:24]!r} is not 1 to {MAX_SEQ_DIGITS} ASCII digits",
                field="attachment.seq",
            )
        return cls(parts[0], int(number), parts[2], parts[3])


Bundled = tuple[
    str, Tag, "bytes | dict[str, Any]"
]  # a message carried inside another: key, tag, payload or a note


def bundle(header: dict[str, Any], messages: Sequence[Bundled]) -> bytes:
    """One payload holding a JSON header and whole tagged messages. The header lists each message's key,
    tag and either its size (its payload follows the header line, back to back with the others) or a
    JSON note standing for it (see `SimClock` for the one note there is)."""
    listing = [
        [key, tag.encode().decode(), len(content) if isinstance(content, bytes) else content]
        for key, tag, content in messages
    ]
    body = b"".join(content for _, _, content in messages if isinstance(content, bytes))
    return json.dumps({**header, "messages": listing}).encode() + b"\n" + body


def unbundle(data: bytes) -> tuple[dict[str, Any], list[Bundled]]:
    """The header and the messages of a `bundle`."""
    head, _, body = data.partition(b"\n")
    header = json.loads(head)
    messages: list[Bundled] = []
    offset = 0
    for key, tag, content in header.pop("messages", []):
        try:
            decoded = Tag.decode(tag.encode())
        except BadTag:
            decoded = None
        if decoded is None:
            raise PegbtError(f"bundled message on {key} has no valid tag: {tag[:40]!r}", field=key)
        if isinstance(content, int):
            size = content
            content, offset = body[offset : offset + size], offset + size
        messages.append((key, decoded, content))
    return header, messages


class Source:
    """A sender identity (one per process and session) with one message counter per key."""

    def __init__(self, name: str | None = None) -> None:
        self.name = name or uuid.uuid4().hex[:12]
        self._counts: dict[str, int] = {}
        self._lock = threading.Lock()

    def next_tag(self, key: str, cause: str = "", outcome: str = "") -> Tag:
        with self._lock:
            seq = self._counts.get(key, 0) + 1
            self._counts[key] = seq
        return Tag(self.name, seq, cause, outcome)

    def counts(self) -> dict[str, int]:
        """How many messages went out on each key so far."""
        with self._lock:
            return dict(self._counts)


class Outlet:
    """A publisher that tags every message; commands and events block rather than drop under congestion.

    `express` sends each message at once (lowest latency, for commands and real-time streams); without
    it zenoh batches, which costs a quarter as much per message for bursts such as a lockstep step's state.
    """

    def __init__(
        self,
        session: zenoh.Session,
        key: str,
        source: Source,
        *,
        drop_when_congested: bool = False,
        express: bool = True,
    ) -> None:
        self.key = key
        self._source = source
        congestion = zenoh.CongestionControl.DROP if drop_when_congested else zenoh.CongestionControl.BLOCK
        self._publisher = session.declare_publisher(key, express=express, congestion_control=congestion)
        self.tap: Callable[[str, bytes], None] | None = None  # sees every payload put (a recorder)

    @property
    def matched(self) -> bool:
        """Whether any subscriber (an endpoint, a bridge) listens on this key right now."""
        return bool(self._publisher.matching_status.matching)  # type: ignore[attr-defined]  # zenoh's stub says bool; it is a MatchingStatus

    def put(self, payload: bytes, cause: str = "", outcome: str = "") -> Tag:
        tag = self._source.next_tag(self.key, cause, outcome)
        self._publisher.put(payload, attachment=tag.encode())
        if self.tap is not None:
            self.tap(self.key, payload)
        return tag

    def close(self) -> None:
        self._publisher.undeclare()


class Received(Generic[T]):
    """A message with its tag (None if untagged) and when it arrived (time.monotonic).

    The payload is decoded on first use of `value`: a client that ignores a topic never pays for it.
    """

    __slots__ = ("_payload", "_decode", "_value", "tag", "received_at")

    def __init__(
        self, payload: bytes, decode: Callable[[bytes], T], tag: Tag | None, received_at: float
    ) -> None:
        self._payload: bytes | None = payload
        self._decode = decode
        self._value: T | None = None
        self.tag = tag
        self.received_at = received_at

    @property
    def value(self) -> T:
        """The decoded message; raises `PegbtError` if the payload is not a valid message."""
        if self._payload is not None:
            self._value, self._payload = self._decode(self._payload), None
        return self._value  # type: ignore[return-value]

    @property
    def payload(self) -> bytes | None:
        """The bytes as received, until `value` decodes them (empty for a value given without bytes)."""
        return self._payload


class Inlet(Generic[T]):
    """The latest message on one key, and the highest sequence number seen from each source.

    Messages older (by sequence) than one already kept are ignored, so a jittery link never rolls the
    state back. A payload that fails to decode raises when its `value` is read.
    """

    def __init__(
        self,
        session: zenoh.Session,
        key: str,
        decode: Callable[[bytes], T],
        on_message: Callable[[Received[T]], None] | None = None,
    ) -> None:
        self.key = key
        self._decode = decode
        self._on_message = on_message
        self._latest: Received[T] | None = None
        self._seen: dict[str, int] = {}
        self._changed = threading.Condition()
        self.tap: Callable[[str, Received[T]], None] | None = None  # sees every message taken (a recorder)
        self.bad_tags = 0  # messages dropped because their attachment was not a tag
        self._subscriber = session.declare_subscriber(key, self._receive)

    def _receive(self, sample: zenoh.Sample) -> None:
        try:
            tag = Tag.decode(sample.attachment)
        except BadTag as error:
            self.bad_tags += 1
            if self.bad_tags == 1 or self.bad_tags % 1000 == 0:
                LOG.warning(
                    "%s: dropped %d message(s) with a bad attachment: %s", self.key, self.bad_tags, error
                )
            return
        self.deliver(sample.payload.to_bytes(), tag)

    def deliver(self, payload: bytes, tag: Tag | None) -> None:
        """Take a message of this key, whether it came on the key itself or bundled in a step's reply."""
        self.take(Received(payload, self._decode, tag, time.monotonic()))

    def take(self, received: Received[T]) -> None:
        """Take a message already wrapped (with its own way to decode it)."""
        tag = received.tag
        with self._changed:
            if tag is not None and tag.seq <= self._seen.get(tag.source, 0):
                return
            self._latest = received
        if self.tap is not None:
            self.tap(self.key, received)
        if self._on_message is not None:
            try:
                self._on_message(received)
            except PegbtError:
                pass  # a corrupt payload: whoever reads it gets the error
        # Counted only after `on_message` has run, so a lockstep barrier that waits for this message also
        # sees its consequences (a capture handle fulfilled); otherwise a tick may race the callback.
        with self._changed:
            if tag is not None:
                self._seen[tag.source] = max(tag.seq, self._seen.get(tag.source, 0))
            self._changed.notify_all()

    def latest(self) -> Received[T] | None:
        """The newest message, None before the first."""
        return self._latest

    def wait_for(self, source: str, seq: int, timeout: float) -> bool:
        """Block until message `seq` of `source` (or a later one) has arrived; False on timeout."""
        if self._seen.get(source, 0) >= seq:  # already here (the usual case): no lock to take
            return True
        with self._changed:
            return self._changed.wait_for(lambda: self._seen.get(source, 0) >= seq, timeout)

    def wait_for_any(self, timeout: float) -> bool:
        """Block until at least one message has arrived; False on timeout."""
        with self._changed:
            return self._changed.wait_for(lambda: self._latest is not None, timeout)

    def close(self) -> None:
        self._subscriber.undeclare()
