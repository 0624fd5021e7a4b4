"""Tree files and what they include: the top-level structure, subtree definitions and include cycles.

A tree file is a mapping with these keys (all optional, but a file must have `tree` or `subtrees`):

- `doc`: a description.
- `include`: a list of tree files (paths relative to this file) whose subtree definitions this file uses;
  they must lie in the folder of the tree file being loaded or below it (`allow_include_outside` lifts
  this), at most `MAX_INCLUDE_DEPTH` files deep. No error quotes an included file's content.
- `blackboard`: initial blackboard values, `key: value`, set before the first tick.
- `lists`: named lists of items, each a mapping of subtree arguments (`NAME: [{pick: 1, place: 7}, ...]`),
  which `for_each` runs a subtree over; a name is defined once among a file and its includes.
- `subtrees`: definitions, `NAME: {doc, args: {ARG: TYPE | {type, default, doc}}, tree: NODE}`.
- `tree`: the root node.

An included file gives its subtree definitions and its `blackboard` values, as defaults: the including
file's own value of a key wins, and two included files that give one key different values are an error
naming both. An included file's own `tree` is not used.
"""

from __future__ import annotations

import re
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from pegbt.errors import PegbtError, brief
from pegbt.executive.params import REQUIRED, TYPE_NAMES, check_type, is_valid_key, non_finite
from pegbt.executive.problems import Problems, did_you_mean
from pegbt.yamlfile import Located, Mark, read_yaml_file

TOP_LEVEL_KEYS = ("doc", "include", "blackboard", "lists", "subtrees", "tree")
_NAME = re.compile(r"[A-Za-z_][A-Za-z0-9_-]{0,39}")
MAX_INCLUDE_DEPTH = 32  # files including files: far beyond the shipped trees' 3
SUBTREE_KEYS = ("doc", "args", "tree")
ARG_KEYS = ("type", "default", "doc")


@dataclass(frozen=True)
class ArgSpec:
    """A declared subtree argument."""

    name: str
    type: Any
    default: Any
    doc: str
    mark: Mark


@dataclass(frozen=True)
class SubtreeDef:
    """A subtree definition: arguments and body, instantiated by `subtree: {use: NAME, args: ...}`."""

    name: str
    doc: str
    args: dict[str, ArgSpec]
    body: Located
    mark: Mark


@dataclass
class TreeDocument:
    """A tree file with everything it includes."""

    path: Path
    doc: str = ""
    tree: Located | None = None
    blackboard: dict[str, Located] = field(default_factory=dict)
    lists: dict[str, Located] = field(default_factory=dict)
    subtrees: dict[str, SubtreeDef] = field(default_factory=dict)
    own_subtrees: list[str] = field(default_factory=list)
    files: list[Path] = field(default_factory=list)


def load_document(path: Path, problems: Problems, *, allow_include_outside: bool = False) -> TreeDocument:
    """Read `path` and its includes, recording every problem in `problems` (nothing is raised).

    Includes must resolve inside `path`'s folder unless `allow_include_outside`."""
    loader = _DocumentLoader(problems, None if allow_include_outside else Path(path).resolve().parent)
    return loader.load(Path(path), stack=())


class _DocumentLoader:
    def __init__(self, problems: Problems, confine_to: Path | None) -> None:
        self.problems = problems
        self.confine_to = confine_to
        self.cache: dict[Path, TreeDocument] = {}
        self.defined_at: dict[str, Mark] = {}

    def load(self, path: Path, stack: tuple[Path, ...]) -> TreeDocument:
        resolved = path.resolve()
        if resolved in self.cache:
            return self.cache[resolved]
        document = TreeDocument(path=path, files=[path])
        self.cache[resolved] = document
        try:
            root = read_yaml_file(path)
        except PegbtError as error:
            self.problems.add_error(error)
            return document
        if root is None:
            self.problems.add(
                "the file is empty; expected a mapping with `tree:` and/or `subtrees:`", Mark(str(path), 1, 1)
            )
            return document
        if not root.is_map:
            self.problems.add(
                f"not a tree file: expected a mapping with keys {', '.join(TOP_LEVEL_KEYS)}; found {_shape(root)}",
                root.mark,
            )
            return document
        for key, value in root.value.items():
            if key in TOP_LEVEL_KEYS:
                continue
            if _NAME.fullmatch(key):
                self.problems.add(
                    f"unknown top-level key {key!r}{did_you_mean(key, TOP_LEVEL_KEYS)}; expected {', '.join(TOP_LEVEL_KEYS)}",
                    root.key_marks[key],
                    field=key,
                )
            else:  # not a name someone meant as a key: quoting it could show a secret file's line
                self.problems.add(
                    f"not a tree file: a top-level key of {len(key)} characters is no name; expected "
                    f"{', '.join(TOP_LEVEL_KEYS)}",
                    root.key_marks[key],
                )
        if not {"tree", "subtrees", "lists"} & set(root.value):
            self.problems.add("nothing to run or share: expected `tree:`, `subtrees:` or `lists:`", root.mark)
        document.doc = self._text(root, "doc")
        document.tree = root.value.get("tree")
        document.blackboard = self._blackboard(root.value.get("blackboard"))
        own_keys = set(document.blackboard)
        for include_path, mark in self._includes(root.value.get("include"), path):
            included = self._include(document, include_path, mark, stack + (path.resolve(),))
            if included is not None:
                self._defaults(document, included, own_keys)
        for name, items in self._lists(root.value.get("lists")).items():
            first = self.defined_at.get("list " + name)
            if first is not None and first != items.mark:
                self.problems.add(f"list {name!r} is already defined at {first}", items.mark, field=name)
                continue
            self.defined_at["list " + name] = items.mark
            document.lists[name] = items
        for subtree in self._subtrees(root.value.get("subtrees")):
            first = self.defined_at.get(subtree.name)
            if first is not None and first != subtree.mark:
                self.problems.add(
                    f"subtree {subtree.name!r} is already defined at {first}",
                    subtree.mark,
                    field=subtree.name,
                )
                continue
            self.defined_at[subtree.name] = subtree.mark
            document.subtrees[subtree.name] = subtree
            document.own_subtrees.append(subtree.name)
        return document

    def _defaults(self, document: TreeDocument, included: TreeDocument, own_keys: set[str]) -> None:
        """Take the blackboard defaults of an included file, unless this file sets the key itself."""
        for key, value in included.blackboard.items():
            if key in own_keys:
                continue
            first = document.blackboard.setdefault(key, value)
            if first.mark != value.mark and first.plain() != value.plain():
                self.problems.add(
                    f"blackboard key {key!r} has the default {brief(value.plain())} here and "
                    f"{brief(first.plain())} at {first.mark}; set it in {document.path.name} to choose",
                    value.mark,
                    field=key,
                )

    def _include(
        self, document: TreeDocument, path: Path, mark: Mark, stack: tuple[Path, ...]
    ) -> TreeDocument | None:
        try:
            resolved = path.resolve()
            found = path.is_file()
        except (OSError, ValueError) as error:
            self.problems.add(f"included file {brief(str(path), 80)}: {error}", mark, field="include")
            return None
        if resolved in stack:
            chain = " -> ".join(p.name for p in stack[stack.index(resolved) :] + (resolved,))
            self.problems.add(f"include cycle: {chain}", mark, field="include")
            return None
        if self.confine_to is not None and not resolved.is_relative_to(self.confine_to):
            self.problems.add(
                f"included file {brief(str(path), 80)} is outside the tree's folder {self.confine_to} "
                "(`--allow-include-outside` allows it)",
                mark,
                field="include",
            )
            return None
        if len(stack) >= MAX_INCLUDE_DEPTH:
            self.problems.add(
                f"includes nested more than {MAX_INCLUDE_DEPTH} files deep", mark, field="include"
            )
            return None
        if not found:
            self.problems.add(f"included file {brief(str(path), 80)} not found", mark, field="include")
            return None
        included = self.load(path, stack)
        for name, subtree in included.subtrees.items():
            document.subtrees.setdefault(name, subtree)
        for name, items in included.lists.items():
            document.lists.setdefault(name, items)
        document.files.extend(p for p in included.files if p not in document.files)
        return included

    def _text(self, root: Located, key: str) -> str:
        value = root.value.get(key)
        if value is None:
            return ""
        if not isinstance(value.value, str):
            self.problems.add(f"expected a string; found {_kind(value)}", value.mark, field=key)
            return ""
        return value.value

    def _includes(self, value: Located | None, path: Path) -> list[tuple[Path, Mark]]:
        if value is None:
            return []
        items = value.value if value.is_list else [value]
        found = []
        for item in items:
            if not isinstance(item.value, str) or not item.value:
                self.problems.add(f"expected a file path; found {_kind(item)}", item.mark, field="include")
                continue
            found.append((path.parent / item.value, item.mark))
        return found

    def _blackboard(self, value: Located | None) -> dict[str, Located]:
        if value is None:
            return {}
        if not value.is_map:
            self.problems.add(
                f"expected a mapping of blackboard keys to initial values; found {_kind(value)}",
                value.mark,
                field="blackboard",
            )
            return {}
        values = {}
        for key, item in value.value.items():
            if not is_valid_key(key) or "." in key:
                self.problems.add(
                    "not a blackboard key name (letters, digits, _, and / for namespaces)",
                    value.key_marks[key],
                    field=key,
                )
                continue
            if non_finite(item.plain()):
                self.problems.add("expected finite numbers (not NaN or an infinity)", item.mark, field=key)
                continue
            values[key if key.startswith("/") else "/" + key] = item
        return values

    def _lists(self, value: Located | None) -> dict[str, Located]:
        if value is None:
            return {}
        if not value.is_map:
            self.problems.add(
                f"expected a mapping of list names to lists of items; found {_kind(value)}",
                value.mark,
                field="lists",
            )
            return {}
        lists = {}
        for name, items in value.value.items():
            if not items.is_list or not items.value or not all(item.is_map for item in items.value):
                self.problems.add(
                    "expected a non-empty list of items, each a mapping of argument names to values",
                    items.mark,
                    field=name,
                )
                continue
            bad = [
                (key, argument)
                for item in items.value
                for key, argument in item.value.items()
                if non_finite(argument.plain())
            ]
            for key, argument in bad:  # refused in a list no tree of this file uses too
                self.problems.add(
                    "expected finite numbers (not NaN or an infinity)", argument.mark, field=key
                )
            if not bad:
                lists[name] = items
        return lists

    def _subtrees(self, value: Located | None) -> list[SubtreeDef]:
        if value is None:
            return []
        if not value.is_map:
            self.problems.add(
                f"expected a mapping of subtree names to definitions; found {_kind(value)}",
                value.mark,
                field="subtrees",
            )
            return []
        definitions = []
        for name, body in value.value.items():
            mark = value.key_marks[name]
            if not body.is_map:
                self.problems.add(
                    f"expected a mapping with keys {', '.join(SUBTREE_KEYS)}; found {_kind(body)}",
                    body.mark,
                    field=name,
                )
                continue
            for key in body.value:
                if key not in SUBTREE_KEYS:
                    self.problems.add(
                        f"unknown key {key!r} in subtree {name!r}{did_you_mean(key, SUBTREE_KEYS)}; expected {', '.join(SUBTREE_KEYS)}",
                        body.key_marks[key],
                        field=key,
                    )
            if "tree" not in body.value:
                self.problems.add(f"subtree {name!r} has no `tree:`", mark, field=name)
                continue
            definitions.append(
                SubtreeDef(
                    name,
                    self._text(body, "doc"),
                    self._args(body.value.get("args"), name),
                    body.value["tree"],
                    mark,
                )
            )
        return definitions

    def _args(self, value: Located | None, subtree: str) -> dict[str, ArgSpec]:
        if value is None:
            return {}
        if not value.is_map:
            self.problems.add(
                f"expected a mapping of argument names to types; found {_kind(value)}",
                value.mark,
                field="args",
            )
            return {}
        args = {}
        for name, declaration in value.value.items():
            mark = value.key_marks[name]
            fields = declaration.value if declaration.is_map else {"type": declaration}
            for key in fields:
                if key not in ARG_KEYS:
                    self.problems.add(
                        f"unknown key {key!r}{did_you_mean(key, ARG_KEYS)}; expected {', '.join(ARG_KEYS)}",
                        declaration.key_marks[key],
                        field=key,
                    )
            type_value = fields.get("type")
            kind_name = type_value.value if type_value is not None else "any"
            if not isinstance(kind_name, str) or kind_name not in TYPE_NAMES:
                where = type_value.mark if type_value is not None else mark
                self.problems.add(
                    f"unknown argument type {kind_name!r}{did_you_mean(str(kind_name), TYPE_NAMES)}; expected one of "
                    f"{', '.join(TYPE_NAMES)}",
                    where,
                    field=name,
                )
                continue
            kind = TYPE_NAMES[kind_name]
            default = fields["default"].plain() if "default" in fields else REQUIRED
            if default is not REQUIRED and non_finite(default):
                self.problems.add(
                    f"default of argument {name!r} should be finite numbers (not NaN, an infinity or beyond 64 bits)",
                    fields["default"].mark,
                    field=name,
                )
                default = REQUIRED
            if default is not REQUIRED and default is not None:
                default, problem = check_type(default, kind)
                if problem:
                    self.problems.add(
                        f"default of argument {name!r} should be {problem}",
                        fields["default"].mark,
                        field=name,
                    )
            doc = fields["doc"].value if "doc" in fields and isinstance(fields["doc"].value, str) else ""
            args[name] = ArgSpec(name, kind, default, doc, mark)
        return args


def _shape(value: Located) -> str:
    """What a value is, without quoting it (a file that is not a tree may hold anything, secrets too)."""
    if value.is_map:
        return "a mapping"
    if value.is_list:
        return f"a list of {len(value.value)} item(s)"
    if isinstance(value.value, str):
        return f"a text of {len(value.value)} character(s)"
    return "nothing" if value.value is None else f"a {type(value.value).__name__}"


def _kind(value: Located) -> str:
    if value.is_map:
        return "a mapping"
    if value.is_list:
        return "a list"
    return f"{brief(value.value)} ({type(value.value).__name__})" if value.value is not None else "nothing"
