"""Lockstep: simulated time that moves only when a client asks, and the barrier that keeps each step exact.

In lockstep the simulator has no clock of its own. A client's `SimClock.wait(s)` puts a step request
on `sim/step` ("advance this many control periods"); the simulator ticks that many times and puts its
reply on `sim/stepped/<clock>`, the key of that one clock. A put and a put back cost less than a zenoh
query, and a run goes as fast as the two processes can exchange them: many times faster than real
time, and the same every run.

The same every run needs a barrier at each end, because zenoh keeps the order of the messages on one
key but not across keys: a `servo_jp` put just before a step request may arrive after it.

- **Commands before the step.** Every message carries a tag numbering it on its key (`sequencing`).
  The request says how many commands its sender has put on each key (`sent`); the simulator counts
  what it received per sender and key (`arrived`) and handles commands until it holds them all, and
  only then ticks. While it waits, queries are answered and commands applied as they come; another
  clock's step request waits its turn.
- **State after the step.** The reply carries the simulator's own counts, and the client waits until
  every message it subscribes to has arrived up to them.

The request also *claims* the state keys its client subscribes to (see `outbox`): their latest
messages come back inside the reply, in one message instead of a dozen. Keys under loss or latency
faults are never claimable: their faults act on their topics.
"""

from __future__ import annotations

import json
import queue
import threading
import time
from collections.abc import Callable, Mapping
from dataclasses import dataclass
from typing import Any

import zenoh

from pegbt.errors import PegbtError
from pegbt.sim.outbox import Outbox
from pegbt.transport.keys import SimKeys
from pegbt.transport.sequencing import Bundled, Tag, bundle

MAX_STEPS_PER_REQUEST = 1_000_000
BARRIER_TIMEOUT = 5.0  # s to wait for a stepping client's commands to arrive

Inbox = queue.Queue  # of (kind, *details) items; kind "step" holds a step request's payload


@dataclass(frozen=True)
class StepRequest:
    """An admitted request: advance `steps` periods, then answer `clock` with the `claim`ed state."""

    clock: str
    number: int
    steps: int
    claim: set[str]


class Lockstep:
    """Admits step requests (parse, check, barrier, claim) and answers them once the endpoint has ticked."""

    def __init__(
        self,
        session: zenoh.Session,
        keys: SimKeys,
        outbox: Outbox,
        inbox: Inbox,
        handle: Callable[[tuple], None],
        *,
        enabled: bool,
        command_keys: set[str],
        claimable: set[str],
    ) -> None:
        self._session = session
        self._keys = keys
        self._outbox = outbox
        self._inbox = inbox
        self._handle = handle  # what the endpoint does with an inbox item
        self._enabled = enabled
        self._command_keys = command_keys
        self._claimable = claimable
        self._received: dict[str, dict[str, int]] = {}  # per sender, per command key: highest number received
        self._received_lock = threading.Lock()
        self._replies: dict[str, zenoh.Publisher] = {}  # per stepping clock

    def arrived(self, tag: Tag, key: str) -> None:
        """Count a command (from a zenoh thread, once it is queued: a satisfied barrier means it is in the inbox)."""
        with self._received_lock:
            counts = self._received.setdefault(tag.source, {})
            counts[key] = max(counts.get(key, 0), tag.seq)

    def admit(self, payload: bytes) -> StepRequest | None:
        """The request in `payload` once every command its sender sent before it has been handled.

        None if there is nothing to step: a put that is no `SimClock`'s request (nobody to answer), or a
        request refused (answered here with the reason)."""
        try:
            request = json.loads(payload)
            clock, source, number = str(request["clock"]), str(request["source"]), int(request["number"])
        except (ValueError, TypeError, KeyError):
            return None
        try:
            steps = int(request.get("steps", 1))
            if not self._enabled:
                raise PegbtError("the simulator runs in real time; sim/step needs --lockstep", field="steps")
            if not 0 < steps <= MAX_STEPS_PER_REQUEST:
                raise PegbtError(f"steps must be in 1..{MAX_STEPS_PER_REQUEST}, got {steps}", field="steps")
            self._await_commands(source, request.get("sent", {}))
            claim = set(map(str, request.get("claim", []))) & self._claimable
        except (PegbtError, ValueError, TypeError) as error:
            self._put_reply(clock, {"number": number, "error": str(error)}, [])
            return None
        self._outbox.claim(claim)
        return StepRequest(clock, number, steps, claim)

    def answer(self, request: StepRequest, header: dict[str, Any]) -> None:
        """Reply to `request` with `header` (time, counts) and the latest message of each claimed key."""
        state = self._outbox.latest(request.claim, request.clock)
        self._put_reply(request.clock, {"number": request.number, **header}, state)

    def _put_reply(self, clock: str, header: dict[str, Any], state: list[Bundled]) -> None:
        if clock not in self._replies:
            # a dropped reply would hold its client up until it times out: block, as commands do, rather than drop
            self._replies[clock] = self._session.declare_publisher(
                self._keys.stepped(clock), express=True, congestion_control=zenoh.CongestionControl.BLOCK
            )
        self._replies[clock].put(bundle(header, state))

    def _await_commands(self, source: str, sent: Mapping[str, int]) -> None:
        """Handle every command `source` sent before asking to step, then all else already queued."""
        ours = set(sent) & self._command_keys
        deadline = time.monotonic() + BARRIER_TIMEOUT
        later_steps: list[tuple] = []  # other clocks' requests, back in the inbox once this one is admitted
        try:
            while True:
                with self._received_lock:
                    counts = dict(self._received.get(source, {}))
                if all(counts.get(key, 0) >= int(sent[key]) for key in ours):
                    break
                if time.monotonic() > deadline:
                    raise PegbtError(
                        f"commands from {source} never arrived: wanted {sent}, have {counts}", field="sent"
                    )
                try:
                    item = self._inbox.get(timeout=0.001)
                except queue.Empty:
                    continue
                self._take(item, later_steps)
            while True:  # everything counted is queued: drain it
                try:
                    item = self._inbox.get_nowait()
                except queue.Empty:
                    break
                self._take(item, later_steps)
        finally:
            for item in later_steps:
                self._inbox.put(item)

    def _take(self, item: tuple, later_steps: list[tuple]) -> None:
        if item[0] == "step":
            later_steps.append(item)
        else:
            self._handle(item)

    def close(self) -> None:
        for publisher in self._replies.values():
            publisher.undeclare()
