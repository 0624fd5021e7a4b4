"""`ClockTimeout`: py_trees' `Timeout` decorator measured on the executive's clock.

py_trees' own `Timeout` reads `time.monotonic()`; a tree running in simulated time must time out in
simulated seconds, so this subclass asks the injected `Clock` instead and is otherwise the same.
"""

from __future__ import annotations

import py_trees
from py_trees.common import Status

from pegbt.clock import Clock


class ClockTimeout(py_trees.decorators.Timeout):
    """Fails (halting its child) when the child is still running `duration` clock-seconds after it started."""

    def __init__(self, name: str, child: py_trees.behaviour.Behaviour, duration: float, clock: Clock) -> None:
        super().__init__(name=name, child=child, duration=duration)
        self.clock = clock

    def initialise(self) -> None:
        self.finish_time = self.clock.now() + self.duration
        self.wake_at = self.finish_time  # the runner must tick by then, whatever the child says
        self.feedback_message = ""

    def update(self) -> Status:
        if self.decorated.status != Status.RUNNING:
            self.feedback_message = "child finished before the timeout"
            return self.decorated.status
        remaining = self.finish_time - self.clock.now()
        if remaining < 0:
            self.feedback_message = f"timed out after {self.duration:g} s"
            self.decorated.stop(Status.INVALID)
            return Status.FAILURE
        self.feedback_message = f"{remaining:.3g} s left"
        return Status.RUNNING
