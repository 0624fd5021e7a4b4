"""`Leaf`: the base class for pegbt's leaf behaviours (a plain py_trees `Behaviour` with typed parameters).

A leaf gets one `LeafSetup`. Its blackboard client lives in the node's namespace (a subtree instance
gets its own) and has access to exactly the keys the behaviour declared, the keys its key-parameters
name and the keys its `$key` parameters reference. Follow py_trees' conventions: keep `__init__` light,
acquire resources in `setup()` through `self.context.resource(...)`, and in `terminate(new_status)`
stop anything still in motion when `new_status` is `INVALID` (the node was halted). Heavy work goes
to `offload()` (`pegbt.executive.work`): the leaf stays RUNNING until a later tick finds the job done;
a leaf that stops (halted, or done) discards whatever it still had computing.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any, TypeVar

import py_trees
from py_trees.common import Status

from pegbt.errors import PegbtError
from pegbt.executive.params import BlackboardRef, describe
from pegbt.executive.registry import LeafSetup
from pegbt.executive.work import Job

T = TypeVar("T")


def leaf_keys(setup: LeafSetup) -> tuple[set[str], set[str]]:
    """(keys read, keys written) by a leaf, relative to its namespace, as the validator also computes them."""
    reads = set(setup.spec.reads)
    writes = set(setup.spec.writes)
    for param in setup.spec.params:
        value = setup.params.get(param.name)
        if isinstance(value, BlackboardRef):
            reads.add(value.key)
        elif (named := param.key_named(value)) is not None:
            (reads if param.key == "read" else writes).add(named)
    return reads, writes


def _root_key(key: str) -> str:
    return key.split(".", 1)[0]


class Leaf(py_trees.behaviour.Behaviour):
    """A py_trees behaviour built from a tree file's leaf node.

    Attributes: `context` (the run's clock and resources), `params` (checked parameter values),
    `blackboard` (its client), `setup_info` (the whole `LeafSetup`: spec, namespace, ...). A leaf may set
    `log_detail` (JSON-ready values) before it finishes: the tick log records it beside the feedback.
    """

    log_detail: dict[str, Any] | None = None

    def __init__(self, setup: LeafSetup) -> None:
        super().__init__(name=setup.name)
        self.setup_info = setup
        self.context = setup.context
        self.params = setup.params
        self.blackboard = self.attach_blackboard_client(name=setup.name, namespace=setup.namespace)
        self._jobs: list[Job] = []
        reads, writes = leaf_keys(setup)
        for key in reads - writes:
            self.blackboard.register_key(key=_root_key(key), access=py_trees.common.Access.READ)
        for key in writes:
            self.blackboard.register_key(key=_root_key(key), access=py_trees.common.Access.WRITE)

    def offload(self, fn: Callable[..., T], *args: Any) -> Job[T]:
        """Run `fn(*args)` on the run's worker threads; pick the result up on a later tick (`Job.done`,
        `Job.result()`). `fn` must compute from its arguments alone: the tree ticks on meanwhile."""
        job = self.context.work.submit(fn, *args)
        self._jobs.append(job)
        return job

    def adopt(self, job: Job[T]) -> Job[T]:
        """Take over `job`, submitted before this leaf wanted it (work done ahead): discarded as this
        leaf's own jobs are, and the tree counted as waiting for it only from now."""
        job.wanted()
        self._jobs.append(job)
        return job

    def stop(self, new_status: Status = Status.INVALID) -> None:
        super().stop(new_status)
        for job in self._jobs:
            job.discard()
        self._jobs = []

    def param(self, name: str) -> Any:
        """The parameter's value; a `$key` parameter is read from the blackboard now (KeyError if unset) and
        checked as the validator checks a literal (type, choices, minimum): a `PegbtError` if it fails."""
        value = self.params[name]
        if not isinstance(value, BlackboardRef):
            return value
        read = self.blackboard.get(value.key)
        declared = next(param for param in self.setup_info.spec.params if param.name == name)
        checked, problem = declared.check_value(read)
        if problem:
            raise PegbtError(
                f"{self.name}: parameter {name!r} should be {problem}; blackboard key {value.key!r} holds "
                f"{describe(read)}",
                field=name,
            )
        return checked

    def read(self, key: str) -> Any:
        """A declared blackboard key's value (KeyError if nothing wrote it yet)."""
        return self.blackboard.get(key)

    def write(self, key: str, value: Any) -> None:
        """Write a declared blackboard key."""
        self.blackboard.set(key, value, overwrite=True)
