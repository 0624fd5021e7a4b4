"""Generic actions for trees that run without a robot: wait, set a blackboard key, log, scripted outcomes.

Where py_trees has the behaviour (`SetBlackboardVariable`, `StatusQueue`) the factory builds it (or a
minimal subclass); `wait` and `log` are `Leaf`s because they need the executive's clock and parameters
read from the blackboard.
"""

from __future__ import annotations

import logging

import py_trees
from py_trees.common import Status

from pegbt.executive.leaf import Leaf
from pegbt.executive.params import BlackboardRef
from pegbt.executive.registry import LeafSetup

TREE_LOG = logging.getLogger("pegbt.tree")
_STATUSES = {"success": Status.SUCCESS, "failure": Status.FAILURE, "running": Status.RUNNING}


class Wait(Leaf):
    """Running until the clock has advanced `seconds` since the node started."""

    def initialise(self) -> None:
        seconds = float(self.param("seconds"))
        self.end = self.context.clock.now() + seconds
        self.wake_at = self.end  # the runner need not tick before then
        self.feedback_message = f"waiting {seconds:g} s"

    def update(self) -> Status:
        return Status.SUCCESS if self.context.clock.now() >= self.end else Status.RUNNING


def set_blackboard(setup: LeafSetup) -> py_trees.behaviour.Behaviour:
    value = setup.params["value"]
    if isinstance(value, BlackboardRef):
        source = py_trees.blackboard.Client(name=f"{setup.name} (source)", namespace=setup.namespace)
        source.register_key(key=value.key.split(".", 1)[0], access=py_trees.common.Access.READ)
        ref_key = value.key
        value = lambda: source.get(ref_key)  # noqa: E731  # py_trees calls it on every tick
    return py_trees.behaviours.SetBlackboardVariable(
        name=setup.name,
        variable_name=setup.absolute_key(setup.params["key"]),
        variable_value=value,
        overwrite=True,
    )


class Log(Leaf):
    """Logs once per tick and succeeds; the message is also its feedback message."""

    def update(self) -> Status:
        message = self.param("message")
        if self.params["value"] is not None:
            try:
                message = f"{message} {self.param('value')!r}"
            except KeyError:
                message = f"{message} <{self.params['value']} unset>"
        self.feedback_message = message
        TREE_LOG.log(logging.getLevelName(self.params["level"].upper()), "%s", message)
        return Status.SUCCESS


class ScriptedOutcomes(py_trees.behaviours.StatusQueue):
    """py_trees' `StatusQueue` with a feedback message on failure, so logs say why it "failed"."""

    def __init__(self, name: str, queue: list[Status], eventually: Status | None, message: str) -> None:
        super().__init__(name=name, queue=queue, eventually=eventually)
        self.message = message

    def update(self) -> Status:
        status = super().update()
        self.feedback_message = self.message if status == Status.FAILURE else ""
        return status


def scripted(setup: LeafSetup) -> py_trees.behaviour.Behaviour:
    queue = [_STATUSES[outcome] for outcome in setup.params["outcomes"]]
    eventually = queue[-1] if setup.params["then"] == "last" else None
    return ScriptedOutcomes(setup.name, queue, eventually, setup.params["message"])
