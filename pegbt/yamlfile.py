"""The one YAML reader: values that remember where they were written (file, line, column, field).

Every error about a tree or a settings file names `FILE:LINE:COLUMN` and the dotted field, so no loader
works on plain dicts: the YAML node graph (which carries marks) becomes `Located` values, and their
typed accessors (`number`, `array`, `rigid`, `choice`, `mapping`, ...) check and convert in one step.
Anything malformed (bad syntax, duplicate keys, non-string keys, unknown tags, aliases that explode,
nesting that would overflow the parser, files too large) becomes a `PegbtError` with a line number.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING, Any

import yaml

from pegbt.boundedio import read_bytes
from pegbt.errors import PegbtError, brief

if TYPE_CHECKING:
    import numpy as np
    from numpy.typing import NDArray

MAX_FILE_BYTES = 2_000_000
MAX_DEPTH = 100
MAX_VALUES = 200_000
# The settings-wide ceiling for a number without a physical bound of its own: SI values of a bench-top
# robot's cell (metres, seconds, radians, pixels) never come near it, so beyond it is a typo or an attack.
MAX_MAGNITUDE = 1e6
MAX_INTEGER = 2**63 - 1
# libyaml's composer recurses in C and crashes the interpreter beyond ~20 000 nested flow collections;
# past this many brackets we use the pure-Python parser, which fails cleanly instead.
_C_PARSER_BRACKET_LIMIT = 10_000
_MAP_TAG = "tag:yaml.org,2002:map"
_SEQ_TAG = "tag:yaml.org,2002:seq"
_MERGE_TAG = "tag:yaml.org,2002:merge"


class YamlFileError(PegbtError):
    """A YAML file that cannot be read: too large, not a regular file, not UTF-8, or not YAML."""


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
    """A YAML value, where it was written, and its dotted field name from the document's root.

    `value` is a `dict[str, Located]`, a `list[Located]` or a plain scalar. For mappings, `key_marks`
    locates each key, so an error about a field points at the field's name. The typed accessors return
    plain values and raise a `PegbtError` naming this value's file, line, column and field.
    """

    value: Any
    mark: Mark
    key_marks: dict[str, Mark] = field(default_factory=dict)
    path: str = ""  # e.g. `arms.PSM1.translation`, `world.slips[0]`; empty for the document itself

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

    def error(self, message: str, *, at: Mark | None = None, field_name: str | None = None) -> YamlFileError:
        """A `PegbtError` about this value (or, with `at`/`field_name`, about one of its parts)."""
        mark = at or self.mark
        return YamlFileError(
            message, file=mark.file, line=mark.line, column=mark.column, field=field_name or self.path or None
        )

    def child_path(self, key: str) -> str:
        return f"{self.path}.{key}" if self.path else key

    # ------------------------------------------------------------------------------------- structure
    def mapping(self, allowed: tuple[str, ...] | None = None) -> dict[str, Located]:
        """The entries of a mapping; a key outside `allowed` (when given) is an error at that key."""
        if not self.is_map:
            raise self.error(f"expected a mapping, got {_describe(self)}")
        if allowed is not None:
            for key, mark in self.key_marks.items():
                if key not in allowed:
                    raise self.error(
                        f"unknown field; expected one of {', '.join(allowed)}",
                        at=mark,
                        field_name=self.child_path(key),
                    )
        return self.value

    def get(self, key: str) -> Located | None:
        """The entry `key` of a mapping, or None when it is absent."""
        return self.mapping().get(key)

    def __getitem__(self, key: str) -> Located:
        """The entry `key` of a mapping; a missing entry is an error at the mapping."""
        entry = self.get(key)
        if entry is None:
            raise self.error("missing", field_name=self.child_path(key))
        return entry

    def section(self, key: str, allowed: tuple[str, ...] | None = None) -> Located:
        """The mapping at entry `key` (holding only `allowed` fields, when given); an empty mapping when
        the entry is absent, so optional sections read like present ones."""
        entry = self.get(key)
        if entry is None:
            return Located({}, self.mark, path=self.child_path(key))
        entry.mapping(allowed)
        return entry

    def sequence(self) -> list[Located]:
        """The items of a list."""
        if not self.is_list:
            raise self.error(f"expected a list, got {_describe(self)}")
        return self.value

    # ---------------------------------------------------------------------------------------- scalars
    def number(
        self, *, positive: bool = False, low: float = -MAX_MAGNITUDE, high: float = MAX_MAGNITUDE
    ) -> float:
        """A finite number (not a boolean), positive or within [low, high] (default ±`MAX_MAGNITUDE`)."""
        value = self.value
        if isinstance(value, int) and not isinstance(value, bool) and abs(value) > MAX_INTEGER:
            raise self.error(f"expected a number in [{low:g}, {high:g}], got {brief(value)}")
        if isinstance(value, bool) or not isinstance(value, (int, float)) or not math.isfinite(value):
            raise self.error(f"expected a finite number, got {_describe(self)}")
        if positive and not value > 0:
            raise self.error(f"expected a positive number, got {brief(value)}")
        if not low <= value <= high:
            raise self.error(f"expected a number in [{low:g}, {high:g}], got {brief(value)}")
        return float(value)

    def number_or(
        self,
        key: str,
        default: float,
        *,
        positive: bool = False,
        low: float = -MAX_MAGNITUDE,
        high: float = MAX_MAGNITUDE,
    ) -> float:
        """The number at entry `key` of a mapping (checked as `number` does), or `default` when it is absent."""
        entry = self.get(key)
        return default if entry is None else entry.number(positive=positive, low=low, high=high)

    def integer(self, *, low: int = -MAX_INTEGER, high: int = MAX_INTEGER) -> int:
        """A whole number (not a boolean) within [low, high] (default: a signed 64-bit integer)."""
        value = self.value
        if isinstance(value, bool) or not isinstance(value, int):
            raise self.error(f"expected a whole number, got {_describe(self)}")
        if not low <= value <= high:
            raise self.error(f"expected a whole number in [{low}, {high}], got {brief(value)}")
        return value

    def text(self) -> str:
        """A string."""
        if not isinstance(self.value, str):
            raise self.error(f"expected a string, got {_describe(self)}")
        return self.value

    def choice(self, options: tuple[str, ...]) -> str:
        """One of `options`."""
        if self.value not in options:
            raise self.error(f"expected one of {', '.join(options)}, got {_describe(self)}")
        return str(self.value)

    # ----------------------------------------------------------------------------------------- arrays
    def array(self, shape: tuple[int, ...], *, positive: bool = False) -> NDArray[np.float64]:
        """Nested lists of finite numbers of exactly `shape` (a bad element is named by its index)."""
        import numpy as np  # here, not at the top: checking a tree reads YAML without arrays

        wanted = " x ".join(map(str, shape))
        if not shape:
            return np.array(self.number(positive=positive))
        if not self.is_list or len(self.value) != shape[0]:
            raise self.error(f"expected {wanted} finite numbers, got {_describe(self)}")
        return np.array(
            [item.array(shape[1:], positive=positive) for item in self.value], dtype=float
        ).reshape(shape)

    def rigid(self) -> NDArray[np.float64]:
        """A 4×4 transform from this mapping's `rotation` (projected onto SO(3)) and `translation`."""
        import numpy as np

        from pegbt.frames import rigid_transform

        rotation = self["rotation"].array((3, 3))
        u, _, vt = np.linalg.svd(rotation)
        exact = u @ np.diag([1.0, 1.0, np.linalg.det(u @ vt)]) @ vt
        if np.abs(exact - rotation).max() > 0.01:
            raise self["rotation"].error("not a rotation matrix (off by more than 0.01)")
        return rigid_transform(exact, self["translation"].array((3,)))


def _describe(value: Located) -> str:
    """A short description of what a value is, for error messages."""
    if value.is_map:
        return "a mapping"
    if value.is_list:
        return "a list"
    return brief(value.value)


def read_settings_file(path: Path) -> Located:
    """A settings file's document, which must be a mapping; merge keys (`<<: *defaults`) are allowed."""
    document = read_yaml_file(path, merge_keys=True)
    if document is None:
        raise YamlFileError(
            "the file is empty; expected a mapping of sections", file=str(path), line=1, column=1
        )
    document.mapping()
    return document


def read_yaml_file(path: Path, *, merge_keys: bool = False) -> Located | None:
    """Parse one YAML file; `None` for a file with no document. Raises `PegbtError` with a location.
    Merge keys (`<<`) are refused unless `merge_keys`: trees have subtrees for sharing, settings files anchors."""
    try:
        data = read_bytes(path, MAX_FILE_BYTES)
    except PegbtError as error:
        raise YamlFileError(error.message, file=str(path)) from None
    return parse_yaml(data, str(path), merge_keys=merge_keys)


def parse_yaml(data: bytes | str, name: str, *, merge_keys: bool = False) -> Located | None:
    """Parse YAML text (one document) into `Located` values; `None` when the text holds no document."""
    raw = data.encode("utf-8", "surrogatepass") if isinstance(data, str) else data
    if len(raw) > MAX_FILE_BYTES:
        line = raw.count(b"\n", 0, MAX_FILE_BYTES) + 1
        raise YamlFileError(
            f"file is {len(raw)} bytes; YAML files are limited to {MAX_FILE_BYTES} bytes (limit reached here)",
            file=name,
            line=line,
            column=1,
        )
    text = _decode(raw, name)
    node = _compose(text, name)
    if node is None:
        return None
    return _Converter(name, merge_keys).convert(node, depth=0, path="")


def _decode(raw: bytes, name: str) -> str:
    try:
        return raw.decode("utf-8")
    except UnicodeDecodeError as error:
        line = raw.count(b"\n", 0, error.start) + 1
        column = error.start - (raw.rfind(b"\n", 0, error.start) + 1) + 1
        raise YamlFileError("not UTF-8 text", file=name, line=line, column=column) from None


def _position(text: str, index: int) -> tuple[int, int]:
    line = text.count("\n", 0, index) + 1
    return line, index - (text.rfind("\n", 0, index) + 1) + 1


def _flow_depth(text: str) -> tuple[int, int]:
    """(deepest nesting of flow brackets, where it is reached), counting brackets inside quotes too: an
    over-estimate refuses a rare odd file, never lets a deep one through to a parser that would crash."""
    depth = deepest = at = 0
    for index, char in enumerate(text):
        if char in "[{":
            depth += 1
            if depth > deepest:
                deepest, at = depth, index
        elif char in "]}" and depth:
            depth -= 1
    return deepest, at


def _compose(text: str, name: str) -> yaml.Node | None:
    brackets = text.count("[") + text.count("{")
    if brackets > _C_PARSER_BRACKET_LIMIT:
        deepest, at = _flow_depth(text)
        if deepest > MAX_DEPTH:
            line, column = _position(text, at)
            raise YamlFileError(
                f"nested more than {MAX_DEPTH} levels deep", file=name, line=line, column=column
            )
    use_c = getattr(yaml, "__with_libyaml__", False) and brackets <= _C_PARSER_BRACKET_LIMIT
    loader = yaml.CSafeLoader(text) if use_c else yaml.SafeLoader(text)
    try:
        return loader.get_single_node()
    except yaml.MarkedYAMLError as error:
        mark = error.problem_mark or error.context_mark
        problem = error.problem or error.context or "invalid YAML"
        line, column = (mark.line + 1, mark.column + 1) if mark else (1, 1)
        raise YamlFileError(f"YAML syntax: {problem}", file=name, line=line, column=column) from None
    except yaml.reader.ReaderError as error:
        line, column = _position(text, error.position)
        raise YamlFileError(
            f"YAML: character {error.character!r} is not allowed", file=name, line=line, column=column
        ) from None
    except RecursionError:
        raise YamlFileError(
            "YAML nesting is too deep",
            file=name,
            line=getattr(loader, "line", 0) + 1,
            column=getattr(loader, "column", 0) + 1,
        ) from None
    except yaml.YAMLError as error:
        raise YamlFileError(f"YAML: {error}", file=name, line=1, column=1) from None
    finally:
        loader.dispose()


class _Converter:
    """Walks a composed node graph into `Located` values, checking what plain YAML loading ignores."""

    def __init__(self, name: str, merge_keys: bool) -> None:
        self.name = name
        self.merge_keys = merge_keys
        self.count = 0
        self.scalars = yaml.constructor.SafeConstructor()

    def mark(self, node: yaml.Node) -> Mark:
        return Mark(self.name, node.start_mark.line + 1, node.start_mark.column + 1)

    def convert(self, node: yaml.Node, depth: int, path: str) -> Located:
        mark = self.mark(node)
        self.count += 1
        if self.count > MAX_VALUES:
            raise YamlFileError(
                f"more than {MAX_VALUES} YAML values (aliases expanding?)",
                file=self.name,
                line=mark.line,
                column=mark.column,
            )
        if depth > MAX_DEPTH:
            raise YamlFileError(
                f"nested more than {MAX_DEPTH} levels deep",
                file=self.name,
                line=mark.line,
                column=mark.column,
            )
        if isinstance(node, yaml.MappingNode):
            return self._mapping(node, mark, depth, path)
        if isinstance(node, yaml.SequenceNode):
            self._check_tag(node, _SEQ_TAG, mark)
            return Located(
                [self.convert(item, depth + 1, f"{path}[{i}]") for i, item in enumerate(node.value)],
                mark,
                path=path,
            )
        return Located(self._scalar(node, mark), mark, path=path)

    def _check_tag(self, node: yaml.Node, expected: str, mark: Mark) -> None:
        if node.tag != expected:
            raise YamlFileError(
                f"YAML tag {node.tag!r} is not supported here",
                file=self.name,
                line=mark.line,
                column=mark.column,
            )

    def _mapping(self, node: yaml.MappingNode, mark: Mark, depth: int, path: str) -> Located:
        self._check_tag(node, _MAP_TAG, mark)
        inherited = self._merge(node, mark) if self.merge_keys else 0
        values: dict[str, Located] = {}
        key_marks: dict[str, Mark] = {}
        written: set[str] = set()  # keys written in this mapping itself (merged ones may be overridden)
        for index, (key_node, value_node) in enumerate(node.value):
            key_mark = self.mark(key_node)
            if not isinstance(key_node, yaml.ScalarNode):
                raise YamlFileError(
                    "mapping keys must be plain strings, found a collection",
                    file=self.name,
                    line=key_mark.line,
                    column=key_mark.column,
                )
            key = "<<" if key_node.tag == _MERGE_TAG else self._scalar(key_node, key_mark)
            if not isinstance(key, str) or key == "<<":
                shown = "a merge key (<<)" if key == "<<" else f"{type(key).__name__} {key!r} (quote it)"
                raise YamlFileError(
                    f"mapping keys must be plain strings, found {shown}",
                    file=self.name,
                    line=key_mark.line,
                    column=key_mark.column,
                )
            if key in written:
                first = key_marks[key]
                raise YamlFileError(
                    f"duplicate key {key!r} (first at line {first.line})",
                    file=self.name,
                    line=key_mark.line,
                    column=key_mark.column,
                )
            if index >= inherited:
                written.add(key)
            key_marks[key] = key_mark
            values[key] = self.convert(value_node, depth + 1, f"{path}.{key}" if path else key)
        return Located(values, mark, key_marks, path)

    def _merge(self, node: yaml.MappingNode, mark: Mark) -> int:
        """Replace merge keys (`<<: *anchor`) by the entries they bring; how many now lead `node.value`."""
        own = sum(1 for key, _ in node.value if key.tag != _MERGE_TAG)
        try:
            self.scalars.flatten_mapping(node)
        except yaml.YAMLError as error:
            problem = getattr(error, "problem", None) or str(error)
            raise YamlFileError(
                f"bad merge key: {problem}", file=self.name, line=mark.line, column=mark.column
            ) from None
        return len(node.value) - own

    def _scalar(self, node: yaml.Node, mark: Mark) -> Any:
        try:
            return self.scalars.construct_object(node, deep=True)
        except (yaml.YAMLError, ValueError, TypeError, OverflowError) as error:
            problem = getattr(error, "problem", None) or str(error)
            if "could not determine a constructor" in problem:
                problem = f"YAML tag {node.tag!r} is not supported"
            raise YamlFileError(
                f"bad YAML value: {problem}", file=self.name, line=mark.line, column=mark.column
            ) from None
