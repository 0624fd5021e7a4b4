"""`SimClock`: simulated time for the executive (the `pegbt.clock.Clock` protocol).

It drives the simulator in lockstep: `wait()` asks it to advance by that much simulated time and returns once the
simulator has done so and everything it published on the way has arrived here, so runs are
deterministic and faster than real time, with every timestamp in simulated time.
"""

from __future__ import annotations

import math
import time

from pegbt.clock import Clock, WallClock
from pegbt.errors import PegbtError
from pegbt.transport.keys import SimKeys
from pegbt.transport.link import Link


class SimClock:
    """The simulator's clock, as seen by one client process.

    In lockstep mode `wait(s)` advances the simulator by whole control periods (carrying the remainder
    over, so many short waits add up exactly) and blocks until it has; in real-time mode it sleeps.
    """

    def __init__(self, link: Link, *, reply_timeout: float = 10.0, probe_timeout: float | None = None) -> None:
        """`probe_timeout`: how long the first question may take (short, to tell a simulator from a robot);
        `reply_timeout`: how long each step may take beyond the simulated time it covers."""
        self._link = link
        self._keys = SimKeys(link.namespace)
        self._reply_timeout = reply_timeout
        info = link.query(self._keys.clock, {}, reply_timeout if probe_timeout is None else probe_timeout)
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
        request = {"steps": steps, "source": self._link.source.name, "sent": self._link.source.counts()}
        # a long step may take the simulator as long as real time would on a busy machine: allow that on top
        reply = self._link.query(self._keys.step, request, self._reply_timeout + steps * self.period)
        self._time = reply["time"]
        self._await_published(reply["source"], reply["sent"])

    def _await_published(self, source: str, sent: dict[str, int]) -> None:
        """Barrier: wait until every inlet of this link holds what the simulator sent on its key."""
        deadline = time.monotonic() + self._reply_timeout
        for inlet in self._link.inlets:
            seq = sent.get(inlet.key, 0)
            if seq > self._before.get(inlet.key, 0) and not inlet.wait_for(source, seq, max(0.0, deadline - time.monotonic())):
                raise PegbtError(f"simulator published {inlet.key} #{seq} but it never arrived", field=inlet.key)
