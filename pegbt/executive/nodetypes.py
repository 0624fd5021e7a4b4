"""The control node types a tree file can use: composites, decorators, `recover` and `subtree`.

Each is declared once with its parameters (shared with validation and `pegbt tree schema`) and a
builder that makes the py_trees node. py_trees' own composites and decorators are used wherever
py_trees has them; `guard`, `recover` and `timeout` use the small subclasses in this package.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from typing import Any, Literal

import py_trees
from py_trees.behaviour import Behaviour

from pegbt.executive.conditions import OPERATORS
from pegbt.executive.context import RunContext
from pegbt.executive.guard import BlackboardGuard
from pegbt.executive.loop import ForEach
from pegbt.executive.params import MAX_COUNT, MAX_SECONDS, Param
from pegbt.executive.recover import Recover
from pegbt.executive.spec import NodeSpec
from pegbt.executive.timeout import ClockTimeout

Shape = Literal["composite", "decorator", "recover", "subtree", "loop"]
Builder = Callable[[NodeSpec, list[Behaviour], RunContext], Behaviour]


@dataclass(frozen=True)
class NodeType:
    """A control node type: how its children are written (`shape`), its parameters and its builder."""

    name: str
    doc: str
    shape: Shape
    params: tuple[Param, ...]
    build: Builder | None  # None for `subtree`, which the validator expands

    @property
    def child_fields(self) -> tuple[str, ...]:
        return {
            "composite": ("children",),
            "decorator": ("child",),
            "recover": ("main", "recovery"),
            "subtree": (),
            "loop": (),
        }[self.shape]


def _memory(default: bool) -> Param:
    return Param(
        "memory",
        bool,
        "resume at the running child (true) or restart from the first child every tick (false)",
        default=default,
    )


def _parallel(spec: NodeSpec, children: list[Behaviour], context: RunContext) -> Behaviour:
    policy_name, synchronise = spec.params["policy"], spec.params["synchronise"]
    if policy_name == "all":
        policy: py_trees.common.ParallelPolicy.Base = py_trees.common.ParallelPolicy.SuccessOnAll(
            synchronise=synchronise
        )
    elif policy_name == "one":
        policy = py_trees.common.ParallelPolicy.SuccessOnOne()
    else:
        chosen = [child for child in children if child.name in spec.params["selected"]]
        policy = py_trees.common.ParallelPolicy.SuccessOnSelected(children=chosen, synchronise=synchronise)
    return py_trees.composites.Parallel(spec.name, policy=policy, children=children)


def _oneshot(spec: NodeSpec, children: list[Behaviour], context: RunContext) -> Behaviour:
    policy = {
        "on_success": py_trees.common.OneShotPolicy.ON_SUCCESSFUL_COMPLETION,
        "on_completion": py_trees.common.OneShotPolicy.ON_COMPLETION,
    }[spec.params["policy"]]
    return py_trees.decorators.OneShot(spec.name, children[0], policy=policy)


def _guard(spec: NodeSpec, children: list[Behaviour], context: RunContext) -> Behaviour:
    key = py_trees.blackboard.Blackboard.absolute_name(spec.namespace, spec.params["key"])
    return BlackboardGuard(spec.name, children[0], key, spec.params["op"], spec.params["value"])


def _decorator(cls: type, **fixed: Any) -> Builder:
    """A builder for a py_trees decorator whose only arguments are name and child."""
    return lambda spec, children, context: cls(name=spec.name, child=children[0], **fixed)


NODE_TYPES: dict[str, NodeType] = {
    node.name: node
    for node in (
        NodeType(
            "sequence",
            "tick children in order; fail at the first failure, succeed when all succeed",
            "composite",
            (_memory(True),),
            lambda spec, children, context: py_trees.composites.Sequence(
                spec.name, memory=spec.params["memory"], children=children
            ),
        ),
        NodeType(
            "selector",
            "fallback: tick children in order; succeed at the first success, fail when all fail",
            "composite",
            (_memory(False),),
            lambda spec, children, context: py_trees.composites.Selector(
                spec.name, memory=spec.params["memory"], children=children
            ),
        ),
        NodeType(
            "parallel",
            "tick every child every tick; any failure fails; success per policy",
            "composite",
            (
                Param(
                    "policy",
                    str,
                    "all: every child succeeds; one: any child succeeds; selected: the children named in `selected` succeed",
                    default="all",
                    choices=("all", "one", "selected"),
                ),
                Param(
                    "synchronise",
                    bool,
                    "(all, selected) do not tick children again once they succeeded",
                    default=True,
                ),
                Param(
                    "selected", list[str], "(selected) names of the children that must succeed", default=[]
                ),
            ),
            _parallel,
        ),
        NodeType(
            "retry",
            "tick the child again after it fails, up to `attempts` attempts in all",
            "decorator",
            (Param("attempts", int, "attempts in all", minimum=1, maximum=MAX_COUNT),),
            lambda spec, children, context: py_trees.decorators.Retry(
                spec.name, children[0], num_failures=spec.params["attempts"]
            ),
        ),
        NodeType(
            "timeout",
            "fail, halting the child, if it is still running after `seconds` (executive clock)",
            "decorator",
            (Param("seconds", float, "time allowed, s", minimum=0.0, maximum=MAX_SECONDS),),
            lambda spec, children, context: ClockTimeout(
                spec.name, children[0], spec.params["seconds"], context.clock
            ),
        ),
        NodeType(
            "inverter",
            "success becomes failure and failure success",
            "decorator",
            (),
            _decorator(py_trees.decorators.Inverter),
        ),
        NodeType(
            "repeat",
            "tick the child again after it succeeds until it succeeded `times` times (-1: forever); fail on failure",
            "decorator",
            (Param("times", int, "successes needed (-1 repeats forever)", minimum=-1, maximum=MAX_COUNT),),
            lambda spec, children, context: py_trees.decorators.Repeat(
                spec.name, children[0], num_success=spec.params["times"]
            ),
        ),
        NodeType(
            "force_success",
            "failure becomes success (running stays running)",
            "decorator",
            (),
            _decorator(py_trees.decorators.FailureIsSuccess),
        ),
        NodeType(
            "force_failure",
            "success becomes failure (running stays running)",
            "decorator",
            (),
            _decorator(py_trees.decorators.SuccessIsFailure),
        ),
        NodeType(
            "oneshot",
            "run the child to completion once, then return that result without ticking it",
            "decorator",
            (
                Param(
                    "policy",
                    str,
                    "on_success: latch only success (a failure runs again next time); on_completion: latch any result",
                    default="on_success",
                    choices=("on_success", "on_completion"),
                ),
            ),
            _oneshot,
        ),
        NodeType(
            "guard",
            "tick the child only while the blackboard condition `key op value` holds; when it stops holding, "
            "halt the child and fail (BT.CPP `_while`)",
            "decorator",
            (
                Param("key", str, "blackboard key to test", key="read"),
                Param("op", str, "comparison", default="==", choices=tuple(OPERATORS)),
                Param("value", Any, "value compared with", default=True),
            ),
            _guard,
        ),
        NodeType(
            "recover",
            "run `main`; on failure run `recovery` and, if it succeeds, retry `main` (Nav2 RecoveryNode)",
            "recover",
            (
                Param(
                    "retries",
                    int,
                    "recoveries allowed before giving up",
                    default=1,
                    minimum=0,
                    maximum=MAX_COUNT,
                ),
            ),
            lambda spec, children, context: Recover(
                spec.name, children[0], children[1], spec.params["retries"]
            ),
        ),
        NodeType(
            "for_each",
            "an instance of subtree `use` per item of list `list` (the tree files' `lists:`), in order: the "
            "item's fields are its arguments (those it declares), with `args` and, if it declares `n`, the "
            "item's position in the list, and if it declares `next`, the next item of the loop (its fields; "
            "the last item gets the declared default), for work done ahead",
            "loop",
            (
                Param("list", str, "name of the list (in `lists:` of this file or an included one)"),
                Param("use", str, "name of the subtree definition run per item"),
                Param("args", dict, "arguments the same for every item", default={}),
                Param("from", int, "first item (position, from 1)", default=1, minimum=1, maximum=MAX_COUNT),
                Param(
                    "to",
                    int,
                    "last item (position; default the last)",
                    default=None,
                    minimum=1,
                    maximum=MAX_COUNT,
                ),
                Param(
                    "on_failure",
                    str,
                    "stop: the loop fails with the item; continue: go on with the next item and succeed",
                    default="stop",
                    choices=("stop", "continue"),
                ),
            ),
            lambda spec, children, context: ForEach(
                spec.name, children, keep_going=spec.params["on_failure"] == "continue"
            ),
        ),
        NodeType(
            "subtree",
            "an instance of a subtree definition, with its own blackboard namespace",
            "subtree",
            (
                Param("use", str, "name of the subtree definition"),
                Param("args", dict, "argument values", default={}),
                Param(
                    "namespace",
                    str,
                    "blackboard namespace of this instance (default: from the name)",
                    default=None,
                ),
            ),
            None,
        ),
    )
}
