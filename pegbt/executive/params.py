"""Typed, documented parameters of tree nodes, and references to blackboard keys.

A node's parameters are declared once as `Param`s; the validator checks every value written in a tree
against them (type, choices, required, unknown names) and the schema command prints them. A parameter
declared `blackboard=True` may be written `$key`: the behaviour then reads that key when it runs
(`$$text` is the literal string `$text`). A parameter declared `key="read"` / `key="write"` names a
blackboard key itself (e.g. `set_blackboard`'s `key`), so the validator knows what the node touches.
"""

from __future__ import annotations

import math
import re
import typing
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any, Literal, TypeGuard

from pegbt.errors import brief

REQUIRED: Any = type("Required", (), {"__repr__": lambda self: "REQUIRED"})()
TYPE_NAMES: dict[str, Any] = {
    "str": str,
    "int": int,
    "float": float,
    "bool": bool,
    "list": list,
    "dict": dict,
    "any": Any,
}
# Stated ranges for numbers a tree gives (a `Param` without a physical bound of its own uses these).
MAX_SECONDS = 86_400.0  # s: a day; no step of a task is meant to wait or be allowed longer
MAX_COUNT = 1_000_000  # attempts, repetitions, recoveries: more is a typo, not a policy
_KEY_PATTERN = re.compile(r"^/?[A-Za-z_][A-Za-z0-9_]*(/[A-Za-z_][A-Za-z0-9_]*)*(\.[A-Za-z_][A-Za-z0-9_]*)*$")


@dataclass(frozen=True)
class BlackboardRef:
    """A parameter value to be read from the blackboard when the node runs (`$key` in a tree file)."""

    key: str

    def __str__(self) -> str:
        return f"${self.key}"


@dataclass(frozen=True)
class Unbound:
    """A subtree argument without a value: a subtree definition checked on its own accepts it anywhere."""

    arg: str


def type_name(kind: Any) -> str:
    """`float`, `list[float]`, `any`: how a type is written in the schema and in error messages."""
    if kind is Any:
        return "any"
    origin = typing.get_origin(kind)
    if origin is not None:
        return f"{origin.__name__}[{', '.join(type_name(arg) for arg in typing.get_args(kind))}]"
    return kind.__name__


def is_valid_key(key: object) -> TypeGuard[str]:
    """Blackboard key syntax: names of letters, digits and `_`, `/` for namespaces, `.` for attributes."""
    return isinstance(key, str) and bool(_KEY_PATTERN.match(key))


def check_type(value: Any, kind: Any) -> tuple[Any, str | None]:
    """`(value converted to kind, None)` or `(value, what was expected)`; ints are accepted as floats."""
    if kind is Any or isinstance(value, Unbound):
        return value, None
    origin = typing.get_origin(kind)
    if origin is list:
        if not isinstance(value, list):
            return value, f"a list of {type_name(typing.get_args(kind)[0])}"
        converted = []
        for index, item in enumerate(value):
            item_value, problem = check_type(item, typing.get_args(kind)[0])
            if problem:
                return value, f"item {index} to be {problem}"
            converted.append(item_value)
        return converted, None
    if kind is float and isinstance(value, int) and not isinstance(value, bool):
        if abs(value) > 1e300:
            return value, "a float of at most 1e300 in magnitude"
        return float(value), None
    if kind in (int, float) and isinstance(value, bool):
        return value, _article(type_name(kind))
    if not isinstance(value, kind):
        return value, _article(type_name(kind))
    return value, None


def _article(name: str) -> str:
    return f"an {name}" if name[0] in "aeiou" else f"a {name}"


def describe(value: Any) -> str:
    """A short account of a value for error messages: `'abc' (str)`."""
    return f"{brief(value)} ({type(value).__name__})"


def non_finite(value: Any) -> bool:
    """Whether a value holds NaN, an infinity or an integer beyond 64 bits anywhere (a number, or inside a
    list or mapping): no quantity a tree gives is either, and the integer cannot even be printed."""
    if isinstance(value, float):
        return not math.isfinite(value)
    if isinstance(value, int):
        return abs(value) > 2**63
    if isinstance(value, list):
        return any(non_finite(item) for item in value)
    if isinstance(value, dict):
        return any(non_finite(item) for item in value.values())
    return False


@dataclass(frozen=True)
class Param:
    """One parameter of a node type or behaviour.

    Attributes:
        name: the field name in the tree file.
        type: `str`, `int`, `float`, `bool`, `list`, `dict`, `typing.Any` or `list[X]`.
        doc: one line for `pegbt tree schema`.
        default: the value when the field is absent; `REQUIRED` (the default) makes it mandatory.
        choices: allowed values (for lists: allowed items).
        blackboard: the value may be `$key`, read from the blackboard each time the node asks for it.
        key: the value is itself a blackboard key that the node reads or writes (or, with `names_key`,
            names one).
        names_key: the key the value names (a handover number names its record's key), when the value is
            not the key itself.
        minimum: smallest allowed number (`int` / `float`) or length (`list`).
        maximum: largest allowed number (`int` / `float`, or each item of a `list[int]` / `list[float]`):
            every number a tree gives has a stated physical range (a duration, a height, a count).
    """

    name: str
    type: Any
    doc: str
    default: Any = REQUIRED
    choices: tuple[Any, ...] = ()
    blackboard: bool = False
    key: Literal["read", "write"] | None = None
    minimum: float | None = None
    maximum: float | None = None
    names_key: Callable[[Any], str] | None = None

    @property
    def required(self) -> bool:
        return self.default is REQUIRED

    def check(self, value: Any) -> tuple[Any, str | None]:
        """`(checked value, None)` or `(value, what was expected)`; `$key` becomes a `BlackboardRef`."""
        if isinstance(value, str) and value.startswith("$"):
            if value.startswith("$$"):
                value = value[1:]
            elif not self.blackboard:
                return (
                    value,
                    f"a literal {type_name(self.type)}; this parameter does not take blackboard references ($key)",
                )
            elif not is_valid_key(value[1:]):
                return value, "a blackboard reference `$name` (letters, digits, _, / and .)"
            else:
                return BlackboardRef(value[1:]), None
        return self.check_value(value)

    def check_value(self, value: Any) -> tuple[Any, str | None]:
        """As `check`, for a value that is never a reference: one read from the blackboard at run time."""
        checked, problem = check_type(value, self.type)
        if problem:
            return value, problem
        if self.key_named(checked) is None and self.key is not None and not isinstance(checked, Unbound):
            return value, "a blackboard key name (letters, digits, _, / for namespaces, . for attributes)"
        if non_finite(checked):
            return value, "a finite number (not NaN, an infinity or beyond 64 bits)"
        numbers = checked if isinstance(checked, list) else [checked]
        for number in numbers:
            if isinstance(number, bool) or not isinstance(number, (int, float)):
                continue
            if self.minimum is not None and not isinstance(checked, list) and number < self.minimum:
                return value, self._range()
            if self.maximum is not None and number > self.maximum:
                return value, self._range()
        if self.minimum is not None and isinstance(checked, list) and len(checked) < self.minimum:
            return value, f"a list of at least {self.minimum:g} item(s)"
        if self.choices and not isinstance(checked, Unbound):
            items = checked if isinstance(checked, list) else [checked]
            for item in items:
                if item not in self.choices:
                    return value, "one of " + ", ".join(repr(choice) for choice in self.choices)
        return checked, None

    def key_named(self, value: Any) -> str | None:
        """The blackboard key a (checked) value of this key parameter names, or None if it names none."""
        if self.key is None or isinstance(value, Unbound):
            return None
        named = self.names_key(value) if self.names_key is not None else value
        return named if is_valid_key(named) else None

    def _range(self) -> str:
        low = "" if self.minimum is None else f" >= {self.minimum:g}"
        high = "" if self.maximum is None else f" <= {self.maximum:g}"
        return f"a number{low}{' and' if low and high else ''}{high}"
