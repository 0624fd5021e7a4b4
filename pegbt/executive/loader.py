"""The executive's front door: load a tree file, validate all of it, and build it.

`check_tree` returns every problem in a file (and its includes) without building anything;
`load_tree` raises them all at once as `PegbtErrors`; `build` turns the result into py_trees.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING, Any

from pegbt.errors import PegbtError
from pegbt.executive.document import TreeDocument, load_document
from pegbt.executive.keys import check_keys
from pegbt.executive.params import check_type, describe
from pegbt.executive.problems import Problems
from pegbt.executive.registry import REGISTRY, BehaviourRegistry
from pegbt.executive.resolve import Resolver
from pegbt.executive.spec import NodeSpec

if TYPE_CHECKING:
    from pegbt.executive.build import BuiltTree
    from pegbt.executive.context import RunContext


@dataclass
class LoadedTree:
    """A validated tree file: the document, the root `NodeSpec` (None for a file of subtrees only)."""

    document: TreeDocument
    root: NodeSpec | None
    overrides: dict[str, Any] = field(default_factory=dict)  # initial values a command set (`set_blackboard`)

    @property
    def initial_blackboard(self) -> dict[str, Any]:
        return {key: value.plain() for key, value in self.document.blackboard.items()} | self.overrides

    def set_blackboard(self, values: Mapping[str, Any], *, asked_by: str = "") -> None:
        """Replace initial values of keys the file's `blackboard:` declares, as a command's parameters;
        `asked_by` names the option that set them (`--protocol paper`; `RunOptions.asked_by`), for the
        error when one is missing; "" for values the caller set itself, refused in the tree's words.

        Why only declared keys, each keeping its type: the file's values are what the validator checked
        the tree against, so a command can change a value but not what the tree reads."""
        declared = {key: value.plain() for key, value in self.document.blackboard.items()}
        for key, value in values.items():
            absolute = key if key.startswith("/") else "/" + key
            if absolute not in declared:
                needs = f"{asked_by} sets it, but " if asked_by else ""
                raise PegbtError(
                    f"{needs}the tree declares no blackboard key {key!r}; "
                    f"it has {', '.join(sorted(declared)) or 'none'}",
                    file=self.document.path,
                    field=key,
                )
            checked, problem = check_type(value, type(declared[absolute]))
            if problem:
                raise PegbtError(
                    f"blackboard key {key!r} holds {problem}, not {describe(value)}",
                    file=self.document.path,
                    field=key,
                )
            self.overrides[absolute] = checked

    def node_count(self) -> int:
        return sum(1 for _ in self.root.walk()) if self.root else 0

    def build(self, context: RunContext | None = None, registry: BehaviourRegistry = REGISTRY) -> BuiltTree:
        """The py_trees tree; a `PegbtError` if the file has no `tree:` or the context lacks a declared resource."""
        from pegbt.executive.build import build_tree  # py_trees, which checking a tree does without
        from pegbt.executive.context import RunContext

        context = context or RunContext()
        if self.root is None:
            raise PegbtError(
                "this file has no `tree:` to build (it only defines subtrees)", file=self.document.path
            )
        built = build_tree(self.root, context, registry)
        built.initial_blackboard = self.initial_blackboard
        built.source = str(self.document.path)
        return built

    def resource_users(self, registry: BehaviourRegistry = REGISTRY) -> dict[str, str]:
        """Each resource the tree's leaves declare, with the first node that needs it (`/path at FILE:LINE:COL`)."""
        users: dict[str, str] = {}
        for node in self.root.walk() if self.root else ():
            spec = registry.get(node.type)
            for name in spec.resources if spec is not None else ():
                users.setdefault(name, f"{node.path} at {node.mark}")
        return users


def _validate(
    path: Path, registry: BehaviourRegistry, allow_include_outside: bool = False
) -> tuple[LoadedTree, Problems]:
    problems = Problems()
    document = load_document(Path(path), problems, allow_include_outside=allow_include_outside)
    resolver = Resolver(document, problems, registry)
    root = resolver.resolve_tree()
    resolver.check_unused_subtrees()
    if root is not None:
        check_keys(root, set(document.blackboard), problems)
    return LoadedTree(document, root), problems


def check_tree(
    path: str | Path, registry: BehaviourRegistry = REGISTRY, *, allow_include_outside: bool = False
) -> list[PegbtError]:
    """Every problem in the tree file at `path` and the files it includes, in file and line order.
    Includes outside `path`'s folder are problems unless `allow_include_outside`."""
    _, problems = _validate(Path(path), registry, allow_include_outside)
    try:
        problems.raise_if_any()
    except PegbtError as error:
        return list(getattr(error, "errors", [error]))
    return []


def load_tree(
    path: str | Path, registry: BehaviourRegistry = REGISTRY, *, allow_include_outside: bool = False
) -> LoadedTree:
    """Load and validate a tree file; raises `PegbtError` / `PegbtErrors` listing every problem."""
    loaded, problems = _validate(Path(path), registry, allow_include_outside)
    problems.raise_if_any()
    return loaded
