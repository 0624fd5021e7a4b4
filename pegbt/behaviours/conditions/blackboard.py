"""Conditions on the blackboard: test a key once (`check_blackboard`), or watch it until it holds
(`wait_blackboard`, how parallel subtrees synchronise).

`check_blackboard` is py_trees' `CheckBlackboardVariableValue`, built by the factory; `wait_blackboard`
is a `Leaf` because it reads keys written `$key` and says what it waits for in its feedback.
"""

from __future__ import annotations

import math

import py_trees
from py_trees.common import Status

from pegbt.executive.conditions import comparison
from pegbt.executive.leaf import Leaf
from pegbt.executive.registry import LeafSetup


def check_blackboard(setup: LeafSetup) -> py_trees.behaviour.Behaviour:
    check = py_trees.common.ComparisonExpression(
        variable=setup.absolute_key(setup.params["key"]),
        value=setup.params["value"],
        operator=comparison(setup.params["op"]),
    )
    return py_trees.behaviours.CheckBlackboardVariableValue(name=setup.name, check=check)


class WaitBlackboard(Leaf):
    """Running until the condition holds; it needs no tick of its own (only another node can change the key)."""

    def initialise(self) -> None:
        self.holds = comparison(self.params["op"])
        self.wake_at = math.inf

    def update(self) -> Status:
        key, op, value = self.params["key"], self.params["op"], self.params["value"]
        try:
            current = self.read(key)
        except KeyError:
            current = "<unset>"
        else:
            if self.holds(current, value):
                self.feedback_message = f"{key} {op} {value!r} (it is {current!r})"
                return Status.SUCCESS
        self.feedback_message = f"waiting for {key} {op} {value!r} (now {current!r})"
        return Status.RUNNING
