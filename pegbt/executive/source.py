"""YAML text to values that remember where they were written (file, line, column).

Every error the executive reports about a tree names `FILE:LINE:COLUMN`, so the loader never works on
plain dicts: it composes the YAML node graph (which carries marks) and turns it into `Located` values.
Anything malformed (bad syntax, duplicate keys, non-string keys, unknown tags, aliases that explode,
nesting that would overflow the parser, files too large) becomes a `PegbtError` with a line number.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import yaml

from pegbt.errors import PegbtError

MAX_FILE_BYTES = 2_000_000
MAX_DEPTH = 100
MAX_VALUES = 200_000
# libyaml's composer recurses in C and crashes the interpreter beyond ~20 000 nested flow collections;
# past this many brackets we use the pure-Python parser, which fails cleanly instead.
_C_PARSER_BRACKET_LIMIT = 10_000
_MAP_TAG = "tag:yaml.org,2002:map"
_SEQ_TAG = "tag:yaml.org,2002:seq"


@dataclass(frozen=True)
class Mark:
    """A position in a source file; line and column count from 1."""

    file: str
    line: int
    column: int

    def __str__(self) -> str:
        return f"{self.file}:{self.line}:{self.column}"


@dataclass
class Located:
    """A YAML value and where it was written.

    `value` is a `dict[str, Located]`, a `list[Located]` or a plain scalar. For mappings, `key_marks`
    locates each key, so an error about a field points at the field's name.
    """

    value: Any
    mark: Mark
    key_marks: dict[str, Mark] = field(default_factory=dict)

    @property
    def is_map(self) -> bool:
        return isinstance(self.value, dict)

    @property
    def is_list(self) -> bool:
        return isinstance(self.value, list)

    def plain(self) -> Any:
        """The value with all location information stripped (nested dicts, lists and scalars)."""
        if isinstance(self.value, dict):
            return {key: item.plain() for key, item in self.value.items()}
        if isinstance(self.value, list):
            return [item.plain() for item in self.value]
        return self.value


def read_yaml_file(path: Path) -> Located | None:
    """Parse one YAML file; `None` for a file with no document. Raises `PegbtError` with a location."""
    name = str(path)
    try:
        data = path.read_bytes()
    except FileNotFoundError:
        raise PegbtError("file not found", file=name) from None
    except OSError as error:
        raise PegbtError(f"cannot read: {error.strerror}", file=name) from None
    return parse_yaml(data, name)


def parse_yaml(data: bytes | str, name: str) -> Located | None:
    """Parse YAML text (one document) into `Located` values; `None` when the text holds no document."""
    raw = data.encode("utf-8", "surrogatepass") if isinstance(data, str) else data
    if len(raw) > MAX_FILE_BYTES:
        line = raw.count(b"\n", 0, MAX_FILE_BYTES) + 1
        raise PegbtError(
            f"file is {len(raw)} bytes; tree files are limited to {MAX_FILE_BYTES} bytes (limit reached here)",
            file=name,
            line=line,
            column=1,
        )
    text = _decode(raw, name)
    node = _compose(text, name)
    if node is None:
        return None
    return _Converter(name).convert(node, depth=0)


def _decode(raw: bytes, name: str) -> str:
    try:
        return raw.decode("utf-8")
    except UnicodeDecodeError as error:
        line = raw.count(b"\n", 0, error.start) + 1
        column = error.start - (raw.rfind(b"\n", 0, error.start) + 1) + 1
        raise PegbtError("not UTF-8 text", file=name, line=line, column=column) from None


def _position(text: str, index: int) -> tuple[int, int]:
    line = text.count("\n", 0, index) + 1
    return line, index - (text.rfind("\n", 0, index) + 1) + 1


def _compose(text: str, name: str) -> yaml.Node | None:
    use_c = getattr(yaml, "__with_libyaml__", False) and (text.count("[") + text.count("{")) <= _C_PARSER_BRACKET_LIMIT
    loader = yaml.CSafeLoader(text) if use_c else yaml.SafeLoader(text)
    try:
        return loader.get_single_node()
    except yaml.MarkedYAMLError as error:
        mark = error.problem_mark or error.context_mark
        problem = error.problem or error.context or "invalid YAML"
        line, column = (mark.line + 1, mark.column + 1) if mark else (1, 1)
        raise PegbtError(f"YAML syntax: {problem}", file=name, line=line, column=column) from None
    except yaml.reader.ReaderError as error:
        line, column = _position(text, error.position)
        raise PegbtError(f"YAML: character {error.character!r} is not allowed", file=name, line=line, column=column) from None
    except RecursionError:
        raise PegbtError(
            "YAML nesting is too deep", file=name, line=getattr(loader, "line", 0) + 1, column=getattr(loader, "column", 0) + 1
        ) from None
    except yaml.YAMLError as error:
        raise PegbtError(f"YAML: {error}", file=name, line=1, column=1) from None
    finally:
        loader.dispose()


class _Converter:
    """Walks a composed node graph into `Located` values, checking what plain YAML loading ignores."""

    def __init__(self, name: str) -> None:
        self.name = name
        self.count = 0
        self.scalars = yaml.constructor.SafeConstructor()

    def mark(self, node: yaml.Node) -> Mark:
        return Mark(self.name, node.start_mark.line + 1, node.start_mark.column + 1)

    def convert(self, node: yaml.Node, depth: int) -> Located:
        mark = self.mark(node)
        self.count += 1
        if self.count > MAX_VALUES:
            raise PegbtError(f"more than {MAX_VALUES} YAML values (aliases expanding?)", file=self.name, line=mark.line, column=mark.column)
        if depth > MAX_DEPTH:
            raise PegbtError(f"nested more than {MAX_DEPTH} levels deep", file=self.name, line=mark.line, column=mark.column)
        if isinstance(node, yaml.MappingNode):
            return self._mapping(node, mark, depth)
        if isinstance(node, yaml.SequenceNode):
            self._check_tag(node, _SEQ_TAG, mark)
            return Located([self.convert(item, depth + 1) for item in node.value], mark)
        return Located(self._scalar(node, mark), mark)

    def _check_tag(self, node: yaml.Node, expected: str, mark: Mark) -> None:
        if node.tag != expected:
            raise PegbtError(f"YAML tag {node.tag!r} is not supported here", file=self.name, line=mark.line, column=mark.column)

    def _mapping(self, node: yaml.MappingNode, mark: Mark, depth: int) -> Located:
        self._check_tag(node, _MAP_TAG, mark)
        values: dict[str, Located] = {}
        key_marks: dict[str, Mark] = {}
        for key_node, value_node in node.value:
            key_mark = self.mark(key_node)
            if not isinstance(key_node, yaml.ScalarNode):
                raise PegbtError("mapping keys must be plain strings, found a collection", file=self.name, line=key_mark.line, column=key_mark.column)
            key = self._scalar(key_node, key_mark)
            if not isinstance(key, str) or key == "<<":
                shown = "a merge key (<<)" if key == "<<" else f"{type(key).__name__} {key!r} (quote it)"
                raise PegbtError(
                    f"mapping keys must be plain strings, found {shown}", file=self.name, line=key_mark.line, column=key_mark.column
                )
            if key in values:
                first = key_marks[key]
                raise PegbtError(
                    f"duplicate key {key!r} (first at line {first.line})", file=self.name, line=key_mark.line, column=key_mark.column
                )
            key_marks[key] = key_mark
            values[key] = self.convert(value_node, depth + 1)
        return Located(values, mark, key_marks)

    def _scalar(self, node: yaml.Node, mark: Mark) -> Any:
        try:
            return self.scalars.construct_object(node, deep=True)
        except (yaml.YAMLError, ValueError, TypeError, OverflowError) as error:
            problem = getattr(error, "problem", None) or str(error)
            if "could not determine a constructor" in problem:
                problem = f"YAML tag {node.tag!r} is not supported"
            raise PegbtError(f"bad YAML value: {problem}", file=self.name, line=mark.line, column=mark.column) from None
