"""The control node types a tree file can use: composites, decorators, `recover` and `subtree`.

Each is declared once with its parameters, shared with validation and `pegbt tree schema`; the builders
that make the py_trees nodes are in `pegbt.executive.nodebuild`, imported only when a tree is built.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any, Literal

from pegbt.executive.conditions import OPERATORS
from pegbt.executive.params import MAX_COUNT, MAX_SECONDS, Param

Shape = Literal["composite", "decorator", "recover", "subtree", "loop"]


@dataclass(frozen=True)
class NodeType:
    """A control node type: how its children are written (`shape`) and its parameters."""

    name: str
    doc: str
    shape: Shape
    params: tuple[Param, ...]

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


NODE_TYPES: dict[str, NodeType] = {
    node.name: node
    for node in (
        NodeType(
            "sequence",
            "tick children in order; fail at the first failure, succeed when all succeed",
            "composite",
            (_memory(True),),
        ),
        NodeType(
            "selector",
            "fallback: tick children in order; succeed at the first success, fail when all fail",
            "composite",
            (_memory(False),),
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
        ),
        NodeType(
            "retry",
            "tick the child again after it fails, up to `attempts` attempts in all",
            "decorator",
            (Param("attempts", int, "attempts in all", minimum=1, maximum=MAX_COUNT),),
        ),
        NodeType(
            "timeout",
            "fail, halting the child, if it is still running after `seconds` (executive clock)",
            "decorator",
            (Param("seconds", float, "time allowed, s", minimum=0.0, maximum=MAX_SECONDS),),
        ),
        NodeType(
            "inverter",
            "success becomes failure and failure success",
            "decorator",
            (),
        ),
        NodeType(
            "repeat",
            "tick the child again after it succeeds until it succeeded `times` times (-1: forever); fail on failure",
            "decorator",
            (Param("times", int, "successes needed (-1 repeats forever)", minimum=-1, maximum=MAX_COUNT),),
        ),
        NodeType(
            "force_success",
            "failure becomes success (running stays running)",
            "decorator",
            (),
        ),
        NodeType(
            "force_failure",
            "success becomes failure (running stays running)",
            "decorator",
            (),
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
        ),
    )
}
