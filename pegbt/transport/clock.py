"""`SimClock`: simulated time for the executive (the `pegbt.clock.Clock` protocol).

It drives the simulator in lockstep: `wait()` asks it to advance by that much simulated time and returns once the
simulator has done so and everything it published on the way has arrived here, so runs are
deterministic and faster than real time, with every timestamp in simulated time. The step's reply
brings back the latest state of every topic this link subscribes to (one message instead of one per
topic: most of a step's cost), a joint state whose values did not change since the last reply as a
note with its new stamp; events and command outcomes still come on their own topics.
"""

from __future__ import annotations

import dataclasses
import json
import math
import threading
import time
import uuid
from typing import Any

import zenoh

from pegbt.clock import Clock, WallClock  # noqa: F401 (pegbt.transport re-exports them from here)
from pegbt.errors import PegbtError
from pegbt.transport import codec
from pegbt.transport.keys import SimKeys
from pegbt.transport.link import EndpointSilent, Link
from pegbt.transport.sequencing import Tag, unbundle

CONNECTION_CHECK_S = 0.1  # while awaiting a step's reply, how often to check that anyone is still connected


class SimClock:
    """The simulator's clock, as seen by one client process.

    In lockstep mode `wait(s)` advances the simulator by whole control periods (carrying the remainder
    over, so many short waits add up exactly) and blocks until it has; in real-time mode it sleeps.
    """

    def __init__(
        self, link: Link, *, reply_timeout: float = 10.0, probe_timeout: float | None = None
    ) -> None:
        """`probe_timeout` (default `reply_timeout`) bounds the first question, whether a simulator is there at
        all; `reply_timeout` bounds every step after it, which a busy machine can make slow."""
        self._link = link
        self._keys = SimKeys(link.namespace)
        self._reply_timeout = reply_timeout
        # steps are a put and a put back, not a query: a query's reply and end cost the simulator more than a step.
        # zenoh drops a put by default when its queue is congested (a large trajectory just sent, a busy machine):
        # a lost request would stall the run until the reply times out, so it blocks, as commands do.
        self._requests = link.session.declare_publisher(
            self._keys.step, express=True, congestion_control=zenoh.CongestionControl.BLOCK
        )
        self._name = uuid.uuid4().hex[
            :12
        ]  # each clock has its own replies (and state notes) even on a shared link
        self._replies = link.session.declare_subscriber(self._keys.stepped(self._name), self._on_reply)
        self._reply: tuple[int, bytes] | None = None
        self._replied = threading.Condition()
        self._request_number = 0
        self.stepped_at: float | None = None  # monotonic time the last step's state had all arrived
        self._bases: dict[
            str, tuple[int, bytes]
        ] = {}  # per key: number and payload of the last full state received
        info = link.query(
            self._keys.clock, {}, probe_timeout or reply_timeout
        )  # also: the simulator sees our subscriber
        self.mode: str = info["mode"]
        self.period: float = info["period"]
        self._time: float = info["time"]
        self._target = self._time
        # What the simulator had sent before this client came: a barrier never waits for those (an earlier
        # client's camera capture, say, was never meant for this one).
        self._before: dict[str, int] = info.get("sent", {}) if info.get("source") else {}

    @property
    def lockstep(self) -> bool:
        return self.mode == "lockstep"

    @property
    def realtime(self) -> bool:
        """False in lockstep: simulated time stands still while the client computes (`pegbt.clock.is_realtime`)."""
        return not self.lockstep

    def now(self) -> float:
        return self._time if self.lockstep else time.time()

    def wait(self, seconds: float) -> None:
        if not math.isfinite(seconds) or seconds < 0:
            raise PegbtError(f"wait needs a finite duration >= 0, got {seconds}", field="seconds")
        if not self.lockstep:
            time.sleep(seconds)
            return
        target = self._target + seconds  # kept only once the simulator has stepped towards it
        steps = math.floor((target - self._time) / self.period + 1e-9)
        if steps <= 0:
            self._target = target
            return
        link = self._link
        self._request_number += 1
        claim = sorted({inlet.key for inlet in link.inlets})  # the state to bring back in the reply
        request = {
            "steps": steps,
            "clock": self._name,
            "source": link.source.name,
            "number": self._request_number,
            "sent": link.source.counts(),
            "claim": claim,
        }
        self._requests.put(json.dumps(request))
        # a long step may take the simulator as long as real time would on a busy machine: allow that on top
        reply, messages = unbundle(self._await_reply(self._request_number, steps * self.period))
        if "error" in reply:
            raise PegbtError(f"simulator refused {self._keys.step}: {reply['error']}", field=self._keys.step)
        for key, tag, content in messages:
            if isinstance(content, bytes):
                link.deliver(key, tag, content)
                self._bases[key] = (tag.seq, content)
            else:
                self._restamp(key, tag, content)
        self._target = target
        self._time = reply["time"]
        self._await_published(reply["source"], reply["sent"])
        self.stepped_at = time.monotonic()

    def _restamp(self, key: str, tag: Tag, note: dict[str, Any]) -> None:
        """The simulator's note that the state on `key` is unchanged but for its stamp: the last full
        message of `key` this clock received, with the new stamp (decoded only if someone reads it)."""
        seq, payload = self._bases.get(key, (None, b""))
        if seq != note["base"]:
            raise PegbtError(
                f"the step reply re-stamps {key} #{note['base']}, but this client last had #{seq}", field=key
            )
        sec, nanosec = note["restamp"]
        self._link.deliver_value(
            key,
            tag,
            lambda: dataclasses.replace(codec.decode_joint_state(payload), stamp=sec + nanosec * 1e-9),
        )
        self._bases[key] = (tag.seq, payload)

    def _on_reply(self, sample: zenoh.Sample) -> None:
        payload = sample.payload.to_bytes()
        number = json.loads(payload.partition(b"\n")[0]).get("number", 0)
        with self._replied:
            self._reply = (number, payload)
            self._replied.notify_all()

    def _await_reply(self, number: int, allowance: float) -> bytes:
        """The reply to request `number`. A `PegbtError` after `reply_timeout` + `allowance` s, or as soon as
        this session is connected to nobody: a simulator that died closed its connection, and no reply can come."""
        deadline = time.monotonic() + self._reply_timeout + allowance
        with self._replied:
            while not self._replied.wait_for(
                lambda: self._reply is not None and self._reply[0] == number,
                max(0.0, min(CONNECTION_CHECK_S, deadline - time.monotonic())),
            ):
                if time.monotonic() >= deadline or not self._connected():
                    key = self._keys.step
                    raise EndpointSilent(
                        f"no simulator answers on {key} (is `pegbt sim --lockstep` running and reachable?)",
                        field=key,
                    )
            assert self._reply is not None
            return self._reply[1]

    def _connected(self) -> bool:
        info = self._link.session.info
        return bool(info.peers_zid() or info.routers_zid())

    def _await_published(self, source: str, sent: dict[str, int]) -> None:
        """Barrier: wait until every inlet of this link holds what the simulator sent on its key."""
        deadline = time.monotonic() + self._reply_timeout
        for inlet in self._link.inlets:
            seq = sent.get(inlet.key, 0)
            if seq > self._before.get(inlet.key, 0) and not inlet.wait_for(
                source, seq, max(0.0, deadline - time.monotonic())
            ):
                raise PegbtError(
                    f"simulator published {inlet.key} #{seq} but it never arrived", field=inlet.key
                )
