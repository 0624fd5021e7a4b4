"""Builder: checked `NodeSpec`s become a plain py_trees tree, with a table of nodes for logs and analysis.

Node ids are the depth-first order of the built tree, so the same file always gives the same ids.
A subtree instance becomes a py_trees `PassThrough` decorator named after the instance, so the
boundary stays visible in displays and logs.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

import py_trees
from py_trees.behaviour import Behaviour

from pegbt.errors import PegbtError
from pegbt.executive.context import RunContext
from pegbt.executive.nodebuild import BUILDERS
from pegbt.executive.registry import REGISTRY, BehaviourRegistry, LeafSetup
from pegbt.executive.spec import NodeSpec


@dataclass(frozen=True)
class BuiltNode:
    """One node of a built tree: its stable id, its spec and the py_trees behaviour."""

    id: int
    parent: int | None
    spec: NodeSpec
    behaviour: Behaviour


@dataclass
class BuiltTree:
    """A py_trees tree built from a tree file: its nodes in id order, the run context its leaves got, initial blackboard values."""

    root: Behaviour
    nodes: list[BuiltNode]
    context: RunContext
    initial_blackboard: dict[str, Any] = field(default_factory=dict)
    source: str = ""


def build_tree(root: NodeSpec, context: RunContext, registry: BehaviourRegistry = REGISTRY) -> BuiltTree:
    """Construct the py_trees tree for `root` (leaves are constructed; nothing is set up or ticked).

    py_trees' blackboard is one per process: building clears it, so build one tree at a time.
    """
    py_trees.blackboard.Blackboard.clear()
    nodes: list[BuiltNode] = []
    behaviour = _build(root, None, context, registry, nodes)
    nodes.sort(key=lambda node: node.id)
    return BuiltTree(root=behaviour, nodes=nodes, context=context)


def _build(
    spec: NodeSpec,
    parent: int | None,
    context: RunContext,
    registry: BehaviourRegistry,
    nodes: list[BuiltNode],
) -> Behaviour:
    node_id = len(nodes)
    nodes.append(None)  # type: ignore[arg-type]  # reserve this node's id before its children take theirs
    children = [_build(child, node_id, context, registry, nodes) for child in spec.children]
    if spec.type == "subtree":
        behaviour: Behaviour = py_trees.decorators.PassThrough(name=spec.name, child=children[0])
    elif spec.type in BUILDERS:
        behaviour = BUILDERS[spec.type](spec, children, context)
    else:
        behaviour = _leaf(spec, context, registry)
    nodes[node_id] = BuiltNode(node_id, parent, spec, behaviour)
    return behaviour


def _leaf(spec: NodeSpec, context: RunContext, registry: BehaviourRegistry) -> Behaviour:
    behaviour_spec = registry.get(spec.type)
    if behaviour_spec is None:
        raise PegbtError(
            f"{spec.path}: behaviour {spec.type!r} is not registered",
            file=spec.mark.file,
            line=spec.mark.line,
        )
    setup = LeafSetup(
        name=spec.name, params=spec.params, namespace=spec.namespace, spec=behaviour_spec, context=context
    )
    behaviour = behaviour_spec.factory(setup)
    if not isinstance(behaviour, Behaviour):
        raise TypeError(
            f"behaviour {spec.type!r} factory returned {type(behaviour).__name__}, not a py_trees Behaviour"
        )
    return behaviour
