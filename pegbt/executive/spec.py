"""`NodeSpec`: one node of a validated tree, before it becomes a py_trees behaviour.

The validator turns YAML into a tree of `NodeSpec`s (subtrees expanded, arguments substituted,
parameters checked and defaulted) without constructing anything; the builder turns that into py_trees.
"""

from __future__ import annotations

from collections.abc import Iterator
from dataclasses import dataclass, field
from typing import Any

from pegbt.yamlfile import Mark

# Nodes from the root to the deepest leaf, subtree instances included: far more than a task needs (the
# peg-transfer trees are under 20), few enough that recursive walks (py_trees ticks, builders) stay
# well inside Python's recursion limit.
MAX_TREE_DEPTH = 100


@dataclass(frozen=True)
class KeyUse:
    """A blackboard key a node reads or writes, as an absolute name, and where the tree file says so."""

    key: str
    access: str  # "read" or "write"
    mark: Mark
    field: str | None = None


@dataclass
class NodeSpec:
    """A checked node: its type (control node type or behaviour name), name, parameters and children."""

    type: str
    name: str
    params: dict[str, Any]
    mark: Mark
    path: str
    namespace: str
    children: list[NodeSpec] = field(default_factory=list)
    keys: list[KeyUse] = field(default_factory=list)
    subtree: str | None = None  # for a subtree instance: "transfer(arm='PSM1')"

    def walk(self) -> Iterator[NodeSpec]:
        """This node and all its descendants, depth first, children in order."""
        yield self
        for child in self.children:
            yield from child.walk()
