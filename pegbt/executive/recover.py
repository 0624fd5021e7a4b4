"""`Recover`: Nav2's RecoveryNode as a py_trees composite (py_trees has no equivalent).

Two children, `main` and `recovery`. Tick `main`; if it succeeds, so does `Recover`. If it fails and
fewer than `retries` recoveries have run, tick `recovery` (in the same tick, as Nav2 does); if the
recovery succeeds, tick `main` again from the start; if the recovery fails, `Recover` fails. When
`main` fails after `retries` successful recoveries, `Recover` fails.
"""

from __future__ import annotations

from collections.abc import Iterator

import py_trees
from py_trees.common import Status

MAIN, RECOVERY = 0, 1


class Recover(py_trees.composites.Composite):
    """Run `main`; on failure run `recovery` and, if it succeeds, retry `main` (at most `retries` times)."""

    def __init__(
        self,
        name: str,
        main: py_trees.behaviour.Behaviour,
        recovery: py_trees.behaviour.Behaviour,
        retries: int,
    ) -> None:
        super().__init__(name, [main, recovery])
        self.retries = retries
        self.recoveries = 0
        self.phase = MAIN

    def tick(self) -> Iterator[py_trees.behaviour.Behaviour]:
        if self.status != Status.RUNNING:
            for child in self.children:
                if child.status != Status.INVALID:
                    child.stop(Status.INVALID)
            self.recoveries = 0
            self.phase = MAIN
            self.feedback_message = ""
            self.initialise()
        while True:
            child = self.children[self.phase]
            self.current_child = child
            yield from child.tick()
            if child.status == Status.RUNNING:
                self.status = Status.RUNNING
                yield self
                return
            outcome = self._next(child.status)
            if outcome is not None:
                self.stop(outcome)
                yield self
                return

    def _next(self, child_status: Status) -> Status | None:
        """Advance the phase after a child finished; the final status when `Recover` is done."""
        if self.phase == MAIN:
            if child_status == Status.SUCCESS:
                return Status.SUCCESS
            if self.recoveries >= self.retries:
                self.feedback_message = f"main failed after {self.recoveries} recover(ies); giving up"
                return Status.FAILURE
            self.phase = RECOVERY
            self.feedback_message = f"main failed; running recovery {self.recoveries + 1} of {self.retries}"
            return None
        if child_status == Status.SUCCESS:
            self.recoveries += 1
            self.phase = MAIN
            self.feedback_message = f"recovery {self.recoveries} succeeded; retrying main"
            return None
        self.feedback_message = f"recovery {self.recoveries + 1} failed"
        return Status.FAILURE
