"""`pegbt tree schema`: every node type and behaviour, its parameters and blackboard keys, as text."""

from __future__ import annotations

from pegbt.executive.document import TOP_LEVEL_KEYS
from pegbt.executive.nodetypes import NODE_TYPES
from pegbt.executive.params import Param, type_name
from pegbt.executive.registry import REGISTRY, BehaviourRegistry


def _param_line(param: Param) -> str:
    facts = [type_name(param.type), "required" if param.required else f"default {param.default!r}"]
    if param.choices:
        facts.append("one of " + "|".join(str(choice) for choice in param.choices))
    if param.minimum is not None:
        facts.append(f">= {param.minimum:g}")
    if param.maximum is not None:
        facts.append(f"<= {param.maximum:g}")
    if param.blackboard:
        facts.append("$key allowed")
    if param.names_key is not None:
        facts.append(f"names blackboard key {param.names_key('N')} ({param.key})")
    elif param.key:
        facts.append(f"blackboard key ({param.key})")
    return f"    {param.name}: {', '.join(facts)} -- {param.doc}"


def schema_text(registry: BehaviourRegistry = REGISTRY) -> str:
    """The schema of tree files: top-level keys, control node types, registered behaviours."""
    lines = [
        f"tree file keys: {', '.join(TOP_LEVEL_KEYS)}",
        "",
        "control node types (every node also takes `name`):",
    ]
    for node_type in NODE_TYPES.values():
        children = f" [{', '.join(node_type.child_fields)}]" if node_type.child_fields else ""
        lines.append(f"  {node_type.name}{children} -- {node_type.doc}")
        lines += [_param_line(param) for param in node_type.params]
    lines += ["", "behaviours (leaves):"]
    for spec in registry:
        lines.append(f"  {spec.name} -- {spec.doc}")
        lines += [_param_line(param) for param in spec.params]
        for label, keys in (
            ("reads", spec.reads),
            ("writes", spec.writes),
            ("needs resources", spec.resources),
        ):
            if keys:
                lines.append(f"    ({label}: {', '.join(keys)})")
    return "\n".join(lines)
