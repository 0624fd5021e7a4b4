"""The outbox: everything the simulator publishes goes through it, and so do the faults that act on it.

A real robot's controller publishes its state at a fixed rate whether or not anyone listens, and the
network in between may lose or delay a message. The simulator does the same through one `Outbox`, so
that a client meets the same situations here as on a robot, and so that publishing costs nothing when
nobody listens:

- **Encoded only when received.** A message is a callable that encodes it (`Message`). The outbox
  keeps the latest message of every key; it encodes it only when it is put on the network, at most
  once. A key nobody subscribes to is never encoded, yet a late subscriber still gets its latest
  message with the next heartbeat (`repeat`).
- **Faults.** Loss and latency from the `FaultPlan` act on each message as it is sent; their draws
  depend on the message's identity (time, command, outcome), not on the sender's random name or on
  call order, so the same script meets the same faults. A delayed message keeps its key's order, and
  every fault goes to the simulator's log with its time.
- **Claimed keys (lockstep).** A stepping client may claim state keys: their messages are not put on
  their topics at all but travel in that client's step reply (`latest`), one message per step
  instead of a dozen. A joint state that changed only its stamp since the client last got it travels
  as a note naming the new stamp (`SimClock` re-stamps the copy it holds): nothing to encode or decode.
"""

from __future__ import annotations

import heapq
import itertools
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np
import zenoh
from numpy.typing import NDArray

from pegbt.sim.fault_plan import FaultInjector
from pegbt.transport import codec
from pegbt.transport.sequencing import Bundled, Outlet, Source

Message = Callable[[], bytes]  # encodes a message when someone will receive it


@dataclass(frozen=True)
class JointStateMessage:
    """A JointState, encoded when called; `content` (all but the stamp) tells an unchanged state."""

    stamp: float
    position: NDArray[np.float64]
    velocity: NDArray[np.float64] | tuple[()] = ()
    names: tuple[str, ...] = ()

    def __call__(self) -> bytes:
        return codec.encode_joint_state(self.stamp, self.position, self.velocity, names=self.names)

    def content(self) -> tuple[tuple[str, ...], bytes, bytes]:
        return self.names, self.position.tobytes(), np.asarray(self.velocity, dtype=float).tobytes()


@dataclass
class _Latest:
    """The latest message of a key: how to encode it, and its bytes once encoded."""

    message: Message | None
    cause: str
    outcome: str
    encoded: bytes | None = None

    def payload(self) -> bytes:
        if self.encoded is None:
            assert self.message is not None
            self.encoded = self.message()
        return self.encoded


# Answers to commands are not a stream a newer message replaces: each refusal and each state change
# must reach the client, so under congestion they wait rather than drop (a 20,000-command burst lost
# 38 refusals on `PSMn/error` when they dropped like joint states).
NEVER_DROPPED = ("error", "operating_state")


class Outbox:
    """Publishes tagged messages, losing or delaying them as the fault plan says (delays keep per-key order)."""

    def __init__(
        self,
        session: zenoh.Session,
        source: Source,
        faults: FaultInjector,
        log: Callable[..., None],
        realtime: bool,
    ) -> None:
        self._session = session
        self._source = source
        self._faults = faults
        self._faulty = faults.plan.loss_probability > 0 or faults.plan.latency > 0 or faults.plan.jitter > 0
        self._log = log
        self._realtime = realtime  # real time: express, and drop stale stream messages rather than block
        self._outlets: dict[str, Outlet] = {}
        self._delayed: list[tuple[float, int, str, bytes, str, str]] = []
        self._last: dict[str, _Latest] = {}
        self.inject = True  # off while publishing the initial state: every key starts with one message
        self._last_due: dict[str, float] = {}
        self._order = itertools.count()
        self._claimed: set[str] = set()
        self.tap: Callable[[str, bytes], None] | None = (
            None  # sees every message sent or bundled (a recorder)
        )
        self._replied: dict[
            str, dict[str, tuple[object, int]]
        ] = {}  # per clock, per key: content and number last sent

    def outlet(self, key: str) -> Outlet:
        if key not in self._outlets:
            stream = key.rsplit("/", 1)[-1] not in NEVER_DROPPED
            self._outlets[key] = Outlet(
                self._session,
                key,
                self._source,
                drop_when_congested=self._realtime and stream,
                express=self._realtime,
            )
            self._outlets[key].tap = self.tap
        return self._outlets[key]

    def claim(self, keys: set[str]) -> None:
        """From now on keep `keys` off their topics: their latest messages go in step replies (`latest`)."""
        self._claimed |= keys

    def send(self, now: float, key: str, message: Message, cause: str = "", outcome: str = "") -> None:
        outlet = self.outlet(key)
        if key in self._claimed or not outlet.matched:
            self._last[key] = _Latest(message, cause, outcome)
            return
        if not (self.inject and self._faulty):
            self._put(outlet, _Latest(message, cause, outcome))
            return
        identity = f"{now:.6f}|{cause.partition(':')[2]}|{outcome}"  # without the sender's random name
        if self._faults.lost(key, identity):
            self._log(now, "fault", fault="loss", key=key)
            return
        delay = self._faults.delay(key, identity)
        if delay > 0:
            due = max(now + delay, self._last_due.get(key, 0.0))
            self._last_due[key] = due
            heapq.heappush(self._delayed, (due, next(self._order), key, message(), cause, outcome))
            self._log(now, "fault", fault="latency", key=key, seconds=round(due - now, 6))
            return
        self._put(outlet, _Latest(message, cause, outcome))

    def _put(self, outlet: Outlet, latest: _Latest) -> None:
        outlet.put(latest.payload(), latest.cause, latest.outcome)
        self._last[outlet.key] = latest

    def release(self, now: float) -> None:
        """Put the delayed messages that are due by `now`."""
        while self._delayed and self._delayed[0][0] <= now + 1e-9:
            _, _, key, payload, cause, outcome = heapq.heappop(self._delayed)
            self._put(self.outlet(key), _Latest(None, cause, outcome, payload))

    def latest(self, keys: set[str], clock: str) -> list[Bundled]:
        """The latest message of each claimed key among `keys`, tagged anew, for `clock`'s step reply: a
        joint state equal but for its stamp to the one it was last sent is a note with the new stamp."""
        replied = self._replied.setdefault(clock, {})
        messages: list[Bundled] = []
        for key in sorted(keys & self._claimed & self._last.keys()):
            latest = self._last[key]
            tag = self._source.next_tag(key, latest.cause, latest.outcome)
            message = latest.message
            content = message.content() if isinstance(message, JointStateMessage) else None
            last = replied.get(key)
            if isinstance(message, JointStateMessage) and last is not None and last[0] == content:
                messages.append((key, tag, {"restamp": codec.seconds_parts(message.stamp), "base": last[1]}))
            else:
                messages.append((key, tag, latest.payload()))
            replied[key] = (content, tag.seq)
            if self.tap is not None:
                self.tap(key, latest.payload())
        return messages

    def record(self, tap: Callable[[str, bytes], None]) -> None:
        """Show `tap` every message from now on: put on its topic (by every outlet) or bundled in a reply."""
        self.tap = tap
        for outlet in self._outlets.values():
            outlet.tap = tap

    def repeat(self, keys: set[str]) -> None:
        """Put the latest message of each of `keys` again, unchanged (same stamp, same values), to whoever listens."""
        for key in keys & self._last.keys():
            outlet = self.outlet(key)
            if outlet.matched:
                latest = self._last[key]
                outlet.put(latest.payload(), latest.cause, latest.outcome)

    def close(self) -> None:
        for outlet in self._outlets.values():
            outlet.close()
