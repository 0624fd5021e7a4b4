"""The one source of time, so that a tree can run in wall time or simulated time.

Everything in the executive and the transport that measures or lets time pass (the runner's tick period, the `timeout`
decorator, the `wait` leaf, tick-log timestamps) asks a `Clock`, never `time` directly. A simulator in
lockstep provides its own clock whose `wait` advances the simulation; `WallClock` sleeps; `ManualClock`
only counts, for tests and benchmarks that must not depend on the machine's speed.
"""

from __future__ import annotations

import time
from typing import Any, Protocol, runtime_checkable


@runtime_checkable
class Clock(Protocol):
    """Time as the tree sees it."""

    def now(self) -> float:
        """Seconds since an arbitrary, fixed origin; never decreases."""
        ...

    def wait(self, seconds: float) -> None:
        """Let `seconds` of this clock's time pass (sleep for a wall clock, step a simulator for a sim clock)."""
        ...


def is_realtime(clock: Any) -> bool:
    """Whether `clock`'s time passes while a tick computes (wall time). A lockstep simulator's clock and
    `ManualClock` say `realtime = False`: their time moves only when waited for, so computing costs none."""
    return bool(getattr(clock, "realtime", True))


class WallClock:
    """Real time in seconds since the epoch, as ROS stamps are (a real dVRK, or the simulator in real time)."""

    realtime = True

    def now(self) -> float:
        return time.time()

    def wait(self, seconds: float) -> None:
        if seconds > 0:
            time.sleep(seconds)


class ManualClock:
    """Time that moves only when `wait` (or `advance`) is called: deterministic runs without a simulator."""

    realtime = False

    def __init__(self, start: float = 0.0) -> None:
        self._now = float(start)

    def now(self) -> float:
        return self._now

    def wait(self, seconds: float) -> None:
        self.advance(seconds)

    def advance(self, seconds: float) -> None:
        """Move time forward by `seconds` (negative values are ignored: time never runs backwards)."""
        if seconds > 0:
            self._now += seconds
