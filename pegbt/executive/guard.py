"""`BlackboardGuard`: BehaviorTree.CPP's `_while` precondition as a py_trees decorator.

py_trees' `EternalGuard` already checks its condition before every tick and halts its child when the
condition fails; this subclass only supplies the condition (a blackboard key compared with a value)
and says in its feedback message why it stopped, so tick logs and `pegbt log why` can show it.
"""

from __future__ import annotations

from typing import Any

import py_trees

from pegbt.executive.conditions import comparison


class BlackboardGuard(py_trees.decorators.EternalGuard):
    """Ticks its child only while `key op value` holds; halts it (and fails) as soon as it does not."""

    def __init__(self, name: str, child: py_trees.behaviour.Behaviour, key: str, op: str, value: Any) -> None:
        self.key = key
        self.op = op
        self.value = value
        self._compare = comparison(op)
        super().__init__(
            name=name, child=child, condition=self._holds, blackboard_keys=[key.split(".", 1)[0]]
        )

    def _holds(self, blackboard: py_trees.blackboard.Client) -> bool:
        try:
            current = blackboard.get(self.key)
        except KeyError:
            self.feedback_message = f"guard: {self.key} is not set"
            return False
        holds = self._compare(current, self.value)
        if not holds:
            self.feedback_message = (
                f"guard: {self.key} {self.op} {self.value!r} no longer holds (value {current!r})"
            )
        return holds
