"""Tagged messages: who sent each one, its number on its key, and which command it answers.

Zenoh delivers the messages of one key in order, but not messages of different keys relative to each
other. So every message carries a small tag as a zenoh attachment (invisible to a ROS 2 bridge):
`source|seq|cause|outcome`. Counting per key lets a lockstep clock wait until everything sent before a
step has arrived (a barrier), and `cause`/`outcome` let a motion handle know exactly when *its* command
was accepted, refused, finished or aborted.
"""

from __future__ import annotations

import threading
import time
import uuid
from collections.abc import Callable
from dataclasses import dataclass
from typing import Generic, TypeVar

import zenoh

from pegbt.errors import PegbtError

T = TypeVar("T")


@dataclass(frozen=True)
class Tag:
    """The attachment of one message."""

    source: str
    seq: int
    cause: str = ""  # id of the command this message reports on
    outcome: str = ""  # accepted, refused, done or aborted

    @property
    def id(self) -> str:
        return f"{self.source}:{self.seq}"

    def encode(self) -> bytes:
        return f"{self.source}|{self.seq}|{self.cause}|{self.outcome}".encode()

    @classmethod
    def decode(cls, raw: zenoh.ZBytes | bytes | None) -> "Tag | None":
        """The tag of an attachment, or None for untagged messages (a ROS 2 bridge, a foreign client)."""
        if raw is None:
            return None
        parts = (raw.to_bytes() if isinstance(raw, zenoh.ZBytes) else raw).decode(errors="replace").split("|")
        if len(parts) != 4 or not parts[1].isdigit():
            return None
        return cls(parts[0], int(parts[1]), parts[2], parts[3])


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
    """A publisher that tags every message; commands and events block rather than drop under congestion."""

    def __init__(self, session: zenoh.Session, key: str, source: Source, *, drop_when_congested: bool = False) -> None:
        self.key = key
        self._source = source
        congestion = zenoh.CongestionControl.DROP if drop_when_congested else zenoh.CongestionControl.BLOCK
        self._publisher = session.declare_publisher(key, express=True, congestion_control=congestion)

    @property
    def matched(self) -> bool:
        """Whether any subscriber (an endpoint, a bridge) listens on this key right now."""
        return bool(self._publisher.matching_status.matching)

    def put(self, payload: bytes, cause: str = "", outcome: str = "") -> Tag:
        tag = self._source.next_tag(self.key, cause, outcome)
        self._publisher.put(payload, attachment=tag.encode())
        return tag

    def close(self) -> None:
        self._publisher.undeclare()


@dataclass(frozen=True)
class Received(Generic[T]):
    """A decoded message with its tag (None if untagged) and when it arrived (time.monotonic)."""

    value: T
    tag: Tag | None
    received_at: float


class Inlet(Generic[T]):
    """The latest decoded message on one key, and the highest sequence number seen from each source.

    Messages older (by sequence) than one already kept are ignored, so a jittery link never rolls the
    state back. A payload that fails to decode is kept as an error and raised on the next read.
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
        self._error: PegbtError | None = None
        self._seen: dict[str, int] = {}
        self._changed = threading.Condition()
        self._subscriber = session.declare_subscriber(key, self._receive)

    def _receive(self, sample: zenoh.Sample) -> None:
        tag = Tag.decode(sample.attachment)
        with self._changed:
            if tag is not None and tag.seq <= self._seen.get(tag.source, 0):
                return
            try:
                received = Received(self._decode(sample.payload.to_bytes()), tag, time.monotonic())
            except PegbtError as error:
                self._error = PegbtError(f"{self.key}: {error.message}", field=self.key)
                received = None
            if tag is not None:
                self._seen[tag.source] = tag.seq
            if received is not None:
                self._latest, self._error = received, None
            self._changed.notify_all()
        if received is not None and self._on_message is not None:
            self._on_message(received)

    def latest(self) -> Received[T] | None:
        """The newest message, None before the first; raises if the newest payload was corrupt."""
        if self._error is not None:
            raise self._error
        return self._latest

    def wait_for(self, source: str, seq: int, timeout: float) -> bool:
        """Block until message `seq` of `source` (or a later one) has arrived; False on timeout."""
        with self._changed:
            return self._changed.wait_for(lambda: self._seen.get(source, 0) >= seq, timeout)

    def wait_for_any(self, timeout: float) -> bool:
        """Block until at least one message has arrived; False on timeout."""
        with self._changed:
            return self._changed.wait_for(lambda: self._latest is not None, timeout)

    def close(self) -> None:
        self._subscriber.undeclare()
