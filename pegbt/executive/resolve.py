"""Validation: a tree document becomes a tree of checked `NodeSpec`s, with every problem recorded.

Walks the YAML of the root node (and, through `subtree` nodes, the definitions it instantiates):
node types and behaviours must exist, fields must be known, parameters present and well typed,
subtree arguments declared and typed, names unique among siblings, namespaces unique, subtrees not
recursive. It never stops at the first problem and never constructs a behaviour.

Subtree arguments are substituted before parameters are checked: a string that is exactly `${arg}`
becomes the argument's value (any type), `${arg}` inside a longer string is replaced by its text.
"""

from __future__ import annotations

import re
from dataclasses import dataclass
from typing import Any

from pegbt.executive.document import SubtreeDef, TreeDocument
from pegbt.executive.nodetypes import NODE_TYPES, NodeType
from pegbt.executive.params import (
    MAX_COUNT,
    REQUIRED,
    BlackboardRef,
    Param,
    Unbound,
    check_type,
    describe,
    is_valid_key,
    non_finite,
)
from pegbt.executive.problems import Problems, did_you_mean
from pegbt.executive.registry import REGISTRY, BehaviourRegistry, BehaviourSpec
from pegbt.executive.spec import MAX_TREE_DEPTH, KeyUse, NodeSpec
from pegbt.yamlfile import Located, Mark

_ARG_PATTERN = re.compile(r"\$\{([^}]*)\}")
_NAMESPACE_CHARS = re.compile(r"[^A-Za-z0-9_]+")


class Siblings(dict[str, Mark]):
    """The names taken among one node's children, and for each default name how many used it, so that
    naming the n-th unnamed `wait` is one step, not n (12,000 unnamed siblings took 19 s)."""

    def __init__(self) -> None:
        super().__init__()
        self.counts: dict[str, int] = {}


@dataclass(frozen=True)
class Scope:
    """Where a node sits: its parent's path, its blackboard namespace, the arguments of its subtree."""

    path: str
    namespace: str
    args: dict[str, Any] | None
    stack: tuple[str, ...] = ()


def absolute_key(namespace: str, key: str) -> str:
    """The absolute blackboard key (without attribute suffix) that `key` names in `namespace`.

    As py_trees' `Blackboard.absolute_name` names it when the tree runs (a unit test holds the two
    together), without importing py_trees to check a tree."""
    if key.startswith("/"):
        name = key
    else:
        name = (namespace if namespace.endswith("/") else namespace + "/") + key.strip("/")
    return name.split(".", 1)[0]


class Resolver:
    """Turns a `TreeDocument` into `NodeSpec`s, recording problems instead of raising."""

    def __init__(
        self, document: TreeDocument, problems: Problems, registry: BehaviourRegistry = REGISTRY
    ) -> None:
        self.document = document
        self.problems = problems
        self.registry = registry
        self.namespaces: dict[str, Mark] = {}
        self.instantiated: set[str] = set()
        self.too_deep = False  # the depth limit is reported once, where it is first reached

    def resolve_tree(self) -> NodeSpec | None:
        """The root `NodeSpec` of the document's `tree`, or None if it has none (or it is unusable)."""
        if self.document.tree is None:
            return None
        return self.node(self.document.tree, Scope(path="", namespace="/", args=None), Siblings())

    def check_unused_subtrees(self) -> None:
        """Check the definitions no instance reached, with their defaults (arguments without one match anything)."""
        for name, definition in self.document.subtrees.items():
            if name not in self.instantiated:
                self.instantiated.add(name)
                args = {
                    arg.name: (Unbound(arg.name) if arg.default is REQUIRED else arg.default)
                    for arg in definition.args.values()
                }
                scope = Scope(path=f"(subtree {name})", namespace="/" + name, args=args, stack=(name,))
                self.node(definition.body, scope, Siblings())

    # -- nodes ---------------------------------------------------------------------------------------------

    def node(self, loc: Located, scope: Scope, siblings: Siblings) -> NodeSpec | None:
        if scope.path.count("/") >= MAX_TREE_DEPTH:
            if not self.too_deep:
                self.too_deep = True
                self.problems.add(
                    f"the tree is nested more than {MAX_TREE_DEPTH} nodes deep here (subtrees included)",
                    loc.mark,
                    path=scope.path,
                )
            return None
        split = self._split(loc, scope)
        if split is None:
            return None
        type_name, fields, field_marks = split
        node_type = NODE_TYPES.get(type_name)
        behaviour = None if node_type else self.registry.get(type_name)
        if node_type is None and behaviour is None:
            known = list(NODE_TYPES) + self.registry.names()
            self.problems.add(
                f"unknown node type or behaviour {type_name!r}{did_you_mean(type_name, known)}; see `pegbt tree schema`",
                loc.mark,
                path=scope.path or "/",
                field=type_name,
            )
            return None
        if node_type is not None:
            declared = node_type.params
        else:
            assert behaviour is not None  # refused above when neither
            declared = behaviour.params
        if node_type is not None and node_type.shape == "subtree":
            return self._subtree(loc, fields, field_marks, scope, siblings)
        if node_type is not None and node_type.shape == "loop":
            return self._loop(loc, fields, field_marks, scope, siblings)
        name = self._name(type_name, fields, field_marks, scope, siblings, loc.mark)
        path = f"{scope.path}/{name}"
        self._unknown_fields(
            type_name, fields, field_marks, declared, node_type.child_fields if node_type else (), path
        )
        params = self._params(declared, fields, field_marks, scope, loc.mark, path)
        spec = NodeSpec(type_name, name, params, loc.mark, path, scope.namespace)
        spec.keys = self._keys(declared, params, fields, field_marks, scope.namespace, behaviour, loc.mark)
        child_scope = Scope(path=path, namespace=scope.namespace, args=scope.args, stack=scope.stack)
        if node_type is not None:
            spec.children = self._children(node_type, fields, field_marks, child_scope, loc.mark, path)
            self._check_parallel(node_type, spec, fields, field_marks)
        return spec

    def _split(self, loc: Located, scope: Scope) -> tuple[str, dict[str, Located], dict[str, Mark]] | None:
        """(type, fields, field marks) of a node written `TYPE: {fields}`, `TYPE: [children]` or `TYPE`."""
        where = scope.path or "/"
        if isinstance(loc.value, str):
            return loc.value, {}, {}
        if not loc.is_map or len(loc.value) != 1:
            found = f"keys {', '.join(loc.value)}" if loc.is_map else describe(loc.plain())
            self.problems.add(
                f"a node is a mapping with one key, its type (e.g. `sequence: {{children: [...]}}`); found {found}",
                loc.mark,
                path=where,
            )
            return None
        ((type_name, body),) = loc.value.items()
        if body.value is None:
            return type_name, {}, {}
        node_type = NODE_TYPES.get(type_name)
        if body.is_list and node_type is not None and node_type.shape == "composite":
            return type_name, {"children": body}, {"children": body.mark}
        if not body.is_map:
            self.problems.add(
                f"the fields of {type_name!r} should be a mapping; found {describe(body.plain())}",
                body.mark,
                path=where,
            )
            return None
        return type_name, body.value, body.key_marks

    def _unknown_fields(
        self,
        type_name: str,
        fields: dict[str, Located],
        marks: dict[str, Mark],
        declared: tuple[Param, ...],
        child_fields: tuple[str, ...],
        path: str,
    ) -> None:
        allowed = ("name",) + child_fields + tuple(param.name for param in declared)
        for key in fields:
            if key not in allowed:
                self.problems.add(
                    f"{type_name} has no field {key!r}{did_you_mean(key, allowed)}; expected {', '.join(allowed)}",
                    marks[key],
                    path=path,
                    field=key,
                )

    def _name(
        self,
        default: str,
        fields: dict[str, Located],
        marks: dict[str, Mark],
        scope: Scope,
        siblings: Siblings,
        mark: Mark,
    ) -> str:
        if "name" in fields:
            name = self._substitute(fields["name"].value, scope, fields["name"].mark)
            if isinstance(name, Unbound):
                name = fields["name"].value  # checked on its own: keep `${arg}` in the name
            if isinstance(name, str) and name and "/" not in name:
                if name in siblings:
                    self.problems.add(
                        f"duplicate name {name!r} among siblings (first at line {siblings[name].line})",
                        marks["name"],
                        path=scope.path or "/",
                        field="name",
                    )
                siblings.setdefault(name, marks["name"])
                return name
            self.problems.add(
                f"name should be a non-empty string without '/'; found {describe(name)}",
                marks["name"],
                path=scope.path or "/",
                field="name",
            )
        name, count = default, siblings.counts.get(default, 1)
        while name in siblings:
            count += 1
            name = f"{default} #{count}"
        siblings.counts[default] = count
        siblings[name] = mark
        return name

    def _params(
        self,
        declared: tuple[Param, ...],
        fields: dict[str, Located],
        marks: dict[str, Mark],
        scope: Scope,
        mark: Mark,
        path: str,
    ) -> dict[str, Any]:
        params: dict[str, Any] = {}
        for param in declared:
            if param.name not in fields:
                if param.required:
                    self.problems.add(
                        f"missing required parameter {param.name!r} ({param.doc})",
                        mark,
                        path=path,
                        field=param.name,
                    )
                params[param.name] = None if param.required else param.default
                continue
            raw = self._substitute(fields[param.name].plain(), scope, fields[param.name].mark, path)
            value, problem = param.check(raw)
            if problem:
                self.problems.add(
                    f"parameter {param.name!r} should be {problem}; found {describe(raw)}",
                    marks[param.name],
                    path=path,
                    field=param.name,
                )
            params[param.name] = value
        return params

    def _keys(
        self,
        declared: tuple[Param, ...],
        params: dict[str, Any],
        fields: dict[str, Located],
        marks: dict[str, Mark],
        namespace: str,
        behaviour: BehaviourSpec | None,
        mark: Mark,
    ) -> list[KeyUse]:
        keys = []
        for param in declared:
            value = params.get(param.name)
            where = marks.get(param.name, mark)
            if isinstance(value, BlackboardRef):
                keys.append(KeyUse(absolute_key(namespace, value.key), "read", where, param.name))
            elif (
                param.key is not None
                and (named := param.key_named(value)) is not None
                and param.name in fields
            ):
                keys.append(KeyUse(absolute_key(namespace, named), param.key, where, param.name))
        if behaviour is not None:
            keys.extend(KeyUse(absolute_key(namespace, key), "read", mark) for key in behaviour.reads)
            keys.extend(KeyUse(absolute_key(namespace, key), "write", mark) for key in behaviour.writes)
        return keys

    def _children(
        self,
        node_type: NodeType,
        fields: dict[str, Located],
        marks: dict[str, Mark],
        scope: Scope,
        mark: Mark,
        path: str,
    ) -> list[NodeSpec]:
        siblings = Siblings()
        if node_type.shape == "composite":
            value = fields.get("children")
            if value is None or not value.is_list or not value.value:
                found = "nothing" if value is None else describe(value.plain())
                self.problems.add(
                    f"{node_type.name} needs `children:`, a non-empty list of nodes; found {found}",
                    marks.get("children", mark),
                    path=path,
                    field="children",
                )
                return []
            children = [self.node(item, scope, siblings) for item in value.value]
        else:
            children = []
            for field_name in node_type.child_fields:
                if field_name not in fields:
                    self.problems.add(
                        f"{node_type.name} needs `{field_name}:`, one node", mark, path=path, field=field_name
                    )
                    continue
                children.append(self.node(fields[field_name], scope, siblings))
        return [child for child in children if child is not None]

    def _check_parallel(
        self, node_type: NodeType, spec: NodeSpec, fields: dict[str, Located], marks: dict[str, Mark]
    ) -> None:
        if node_type.name != "parallel" or spec.params.get("policy") != "selected":
            return
        selected = spec.params.get("selected") or []
        names = [child.name for child in spec.children]
        where = marks.get("selected", spec.mark)
        if not selected:
            self.problems.add(
                "policy 'selected' needs `selected:`, the names of the children that must succeed",
                where,
                path=spec.path,
                field="selected",
            )
        for name in selected if isinstance(selected, list) else []:
            if isinstance(name, str) and name not in names:
                self.problems.add(
                    f"selected child {name!r} is not a child of this parallel{did_you_mean(name, names)}",
                    where,
                    path=spec.path,
                    field="selected",
                )

    # -- subtrees ------------------------------------------------------------------------------------------

    def _subtree(
        self,
        loc: Located,
        fields: dict[str, Located],
        marks: dict[str, Mark],
        scope: Scope,
        siblings: Siblings,
    ) -> NodeSpec | None:
        where = scope.path or "/"
        use_field = fields.get("use")
        use = self._substitute(use_field.value, scope, use_field.mark) if use_field is not None else None
        if not isinstance(use, str):
            self.problems.add(
                f"subtree needs `use:`, the name of a subtree definition; found {describe(use)}",
                use_field.mark if use_field else loc.mark,
                path=where,
                field="use",
            )
            return None
        assert use_field is not None  # a name came from it
        definition = self.document.subtrees.get(use)
        if definition is None:
            self.problems.add(
                f"unknown subtree {use!r}{did_you_mean(use, self.document.subtrees)}; defined: "
                f"{', '.join(sorted(self.document.subtrees)) or 'none'}",
                use_field.mark,
                path=where,
                field="use",
            )
            return None
        self.instantiated.add(use)
        args = self._arguments(definition, fields.get("args"), scope, loc.mark, where)
        given = fields["args"].value if fields.get("args") is not None and fields["args"].is_map else {}
        shown_args = " ".join(
            str(args[arg]) for arg in given if arg in args and isinstance(args[arg], (str, int, float))
        )
        name = self._name(f"{use} {shown_args}".strip(), fields, marks, scope, siblings, loc.mark)
        path = f"{scope.path}/{name}"
        self._unknown_fields("subtree", fields, marks, NODE_TYPES["subtree"].params, (), path)
        namespace = self._namespace(fields.get("namespace"), name, scope, loc.mark, path)
        instance = NodeSpec(
            "subtree",
            name,
            {"use": use, "args": args, "namespace": namespace},
            loc.mark,
            path,
            namespace,
            subtree=f"{use}({', '.join(f'{k}={v!r}' for k, v in args.items())})",
        )
        if use in scope.stack:
            chain = " -> ".join(scope.stack[scope.stack.index(use) :] + (use,))
            self.problems.add(
                f"subtree {use!r} instantiates itself: {chain}", use_field.mark, path=path, field="use"
            )
            return instance
        body = self.node(
            definition.body,
            Scope(path=path, namespace=namespace, args=args, stack=scope.stack + (use,)),
            Siblings(),
        )
        instance.children = [body] if body is not None else []
        return instance

    def _loop(
        self,
        loc: Located,
        fields: dict[str, Located],
        marks: dict[str, Mark],
        scope: Scope,
        siblings: Siblings,
    ) -> NodeSpec:
        """A `for_each`: one instance of the subtree per item of the list, each item's fields its arguments."""
        declared = NODE_TYPES["for_each"].params
        name = self._name("for_each", fields, marks, scope, siblings, loc.mark)
        path = f"{scope.path}/{name}"
        self._unknown_fields("for_each", fields, marks, declared, (), path)
        params = self._params(declared, fields, marks, scope, loc.mark, path)
        spec = NodeSpec("for_each", name, params, loc.mark, path, scope.namespace)
        items = self._items(params, fields, marks, loc.mark, path)
        definition = self.document.subtrees.get(params["use"]) if isinstance(params["use"], str) else None
        if not items or definition is None:
            if definition is None and isinstance(params["use"], str):
                self.problems.add(
                    f"unknown subtree {params['use']!r}{did_you_mean(params['use'], self.document.subtrees)}",
                    marks["use"],
                    path=path,
                    field="use",
                )
            return spec
        given = fields.get("args")
        fixed = given.value if given is not None and given.is_map else {}
        fixed_marks = given.key_marks if given is not None and given.is_map else {}
        local = _NAMESPACE_CHARS.sub("_", path).strip("_")  # the path: unique, where the name may not be
        child_scope = Scope(path=path, namespace=scope.namespace, args=scope.args, stack=scope.stack)
        children = Siblings()
        for index, (position, item) in enumerate(items):
            taken = {key: value for key, value in item.value.items() if key in definition.args}
            args = {**fixed, **taken}
            if "n" in definition.args and "n" not in args:
                args["n"] = Located(position, item.mark)
            if "next" in definition.args and "next" not in args and index + 1 < len(items):
                args["next"] = items[index + 1][1]
            shown = " ".join(
                f"{key} {value.plain()}"
                for key, value in taken.items()
                if not (value.is_map or value.is_list)
            )
            instance = {
                "use": fields["use"],
                "args": Located(args, item.mark, {**fixed_marks, **item.key_marks}),
                "name": Located(f"{position}: {shown}" if shown else str(position), item.mark),
                "namespace": Located(f"loop_{local}/item_{position}", item.mark),
            }
            child = self._subtree(item, instance, dict.fromkeys(instance, item.mark), child_scope, children)
            if child is not None:
                spec.children.append(child)
        return spec

    def _items(
        self,
        params: dict[str, Any],
        fields: dict[str, Located],
        marks: dict[str, Mark],
        mark: Mark,
        path: str,
    ) -> list[tuple[int, Located]]:
        """(position from 1, item) of the loop's list between `from` and `to`; [] with a problem if none."""
        name = params["list"]
        if not isinstance(name, str):
            return []
        items = self.document.lists.get(name)
        if items is None:
            self.problems.add(
                f"unknown list {name!r}{did_you_mean(name, self.document.lists)}; defined: "
                f"{', '.join(sorted(self.document.lists)) or 'none'}",
                marks.get("list", mark),
                path=path,
                field="list",
            )
            return []
        first, last = params["from"], params["to"]
        last = len(items.value) if last is None else last
        if not isinstance(first, int) or not isinstance(last, int) or max(abs(first), abs(last)) > MAX_COUNT:
            return []  # out of its parameter's range: refused there
        if not 1 <= first <= last <= len(items.value):
            self.problems.add(
                f"items {first} to {last} are not in list {name!r} of {len(items.value)} item(s)",
                marks.get("to", marks.get("from", mark)),
                path=path,
                field="to" if "to" in fields else "from",
            )
            return []
        return [(position, items.value[position - 1]) for position in range(first, last + 1)]

    def _arguments(
        self, definition: SubtreeDef, given: Located | None, scope: Scope, mark: Mark, where: str
    ) -> dict[str, Any]:
        values: dict[str, Any] = {}
        if given is not None and not given.is_map:
            self.problems.add(
                f"`args:` should be a mapping of argument names to values; found {describe(given.plain())}",
                given.mark,
                path=where,
                field="args",
            )
            given = None
        entries = given.value if given is not None else {}
        key_marks = given.key_marks if given is not None else {}
        for arg_name, value in entries.items():
            arg = definition.args.get(arg_name)
            if arg is None:
                self.problems.add(
                    f"subtree {definition.name!r} has no argument {arg_name!r}{did_you_mean(arg_name, definition.args)}; "
                    f"declared: {', '.join(definition.args) or 'none'}",
                    key_marks[arg_name],
                    path=where,
                    field=arg_name,
                )
                continue
            raw = self._substitute(value.plain(), scope, value.mark)
            checked, problem = check_type(raw, arg.type)
            if not problem and non_finite(checked):
                problem = "finite numbers (not NaN, an infinity or beyond 64 bits)"
            if problem:
                self.problems.add(
                    f"argument {arg_name!r} should be {problem}; found {describe(raw)}",
                    value.mark,
                    path=where,
                    field=arg_name,
                )
                checked = Unbound(arg_name)  # reported once here, not again wherever the subtree uses it
            values[arg_name] = checked
        for arg in definition.args.values():
            if arg.name not in values:
                if arg.default is REQUIRED:
                    if arg.name not in entries:
                        self.problems.add(
                            f"subtree {definition.name!r} needs argument {arg.name!r}",
                            mark,
                            path=where,
                            field=arg.name,
                        )
                    values[arg.name] = Unbound(arg.name)
                else:
                    values[arg.name] = arg.default
        return {name: values[name] for name in definition.args}

    def _namespace(self, field: Located | None, name: str, scope: Scope, mark: Mark, path: str) -> str:
        local = _NAMESPACE_CHARS.sub("_", name).strip("_") or "subtree"
        if field is not None and field.value is not None:
            value = self._substitute(field.value, scope, field.mark)
            if (
                isinstance(value, str)
                and is_valid_key(value)
                and "." not in value
                and not value.startswith("/")
            ):
                local = value
            else:
                self.problems.add(
                    f"namespace should be a relative blackboard name (letters, digits, _, /); found {describe(value)}",
                    field.mark,
                    path=path,
                    field="namespace",
                )
        namespace = absolute_key(scope.namespace, local)
        first = self.namespaces.get(namespace)
        if first is not None and first != mark:
            self.problems.add(
                f"blackboard namespace {namespace!r} is already used by the subtree instance at {first}; "
                "give this instance another `name:` or `namespace:`",
                mark,
                path=path,
                field="namespace",
            )
        self.namespaces.setdefault(namespace, mark)
        return namespace

    # -- arguments -----------------------------------------------------------------------------------------

    def _substitute(self, value: Any, scope: Scope, mark: Mark, path: str | None = None) -> Any:
        """`value` with `${arg}` references to the enclosing subtree's arguments replaced (problems reported at `path`)."""
        path = path or scope.path or "/"
        if isinstance(value, list):
            return [self._substitute(item, scope, mark, path) for item in value]
        if isinstance(value, dict):
            return {key: self._substitute(item, scope, mark, path) for key, item in value.items()}
        if not isinstance(value, str) or "${" not in value:
            return value
        whole = _ARG_PATTERN.fullmatch(value)
        if whole:
            return self._argument(whole.group(1), scope, mark, path)
        unbound: list[Unbound] = []

        def replace(match: re.Match[str]) -> str:
            argument = self._argument(match.group(1), scope, mark, path)
            if isinstance(argument, Unbound):
                unbound.append(argument)
                return match.group(0)
            return str(argument)

        text = _ARG_PATTERN.sub(replace, value)
        return unbound[0] if unbound else text  # a text with an unknown part cannot be checked either

    def _argument(self, name: str, scope: Scope, mark: Mark, path: str) -> Any:
        """The argument's value; `Unbound` (which every check accepts) when it has none or does not exist."""
        if scope.args is None:
            self.problems.add(
                f"${{{name}}} refers to a subtree argument, but this node is not inside a subtree",
                mark,
                path=path,
            )
        elif name not in scope.args:
            self.problems.add(
                f"unknown subtree argument {name!r}{did_you_mean(name, scope.args)}; declared: "
                f"{', '.join(scope.args) or 'none'}",
                mark,
                path=path,
            )
        else:
            return scope.args[name]
        return Unbound(name)
