"""`SimClock`: simulated time for the executive (the `pegbt.clock.Clock` protocol).

It drives the simulator in lockstep: `wait()` asks it to advance by that much simulated time and returns once the
simulator has done so and everything it published on the way has arrived here, so runs are
deterministic and faster than real time, with every timestamp in simulated time. The step's reply
brings back the latest state of every topic this link subscribes to (one message instead of one per
topic: most of a step's cost); events and command outcomes still come on their own topics.
"""

from __future__ import annotations

import math
import time

from pegbt.clock import Clock, WallClock
from pegbt.errors import PegbtError
from pegbt.transport.keys import SimKeys
from pegbt.transport.link import Link
from pegbt.transport.sequencing import unbundle


class SimClock:
    """The simulator's clock, as seen by one client process.

    In lockstep mode `wait(s)` advances the simulator by whole control periods (carrying the remainder
    over, so many short waits add up exactly) and blocks until it has; in real-time mode it sleeps.
    """

    def __init__(self, link: Link, *, reply_timeout: float = 10.0) -> None:
        self._link = link
        self._keys = SimKeys(link.namespace)
        self._reply_timeout = reply_timeout
        info = link.query(self._keys.clock, {}, reply_timeout)
        self.mode: str = info["mode"]
        self.period: float = info["period"]
        self._time: float = info["time"]
        self._target = self._time

    @property
    def lockstep(self) -> bool:
        return self.mode == "lockstep"

    def now(self) -> float:
        return self._time if self.lockstep else time.time()

    def wait(self, seconds: float) -> None:
        if not math.isfinite(seconds) or seconds < 0:
            raise PegbtError(f"wait needs a finite duration >= 0, got {seconds}", field="seconds")
        if not self.lockstep:
            time.sleep(seconds)
            return
        self._target += seconds
        steps = math.floor((self._target - self._time) / self.period + 1e-9)
        if steps <= 0:
            return
        link = self._link
        claim = sorted({inlet.key for inlet in link.inlets})  # the state to bring back in the reply
        request = {"steps": steps, "source": link.source.name, "sent": link.source.counts(), "claim": claim}
        reply, messages = unbundle(link.ask(self._keys.step, request, self._reply_timeout))
        for key, tag, payload in messages:
            link.deliver(key, tag, payload)
        self._time = reply["time"]
        self._await_published(reply["source"], reply["sent"])

    def _await_published(self, source: str, sent: dict[str, int]) -> None:
        """Barrier: wait until every inlet of this link holds what the simulator sent on its key."""
        deadline = time.monotonic() + self._reply_timeout
        for inlet in self._link.inlets:
            seq = sent.get(inlet.key, 0)
            if seq and not inlet.wait_for(source, seq, max(0.0, deadline - time.monotonic())):
                raise PegbtError(f"simulator published {inlet.key} #{seq} but it never arrived", field=inlet.key)
