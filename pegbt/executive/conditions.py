"""Comparisons of a blackboard value with a literal, shared by the `guard` decorator and `check_blackboard`."""

from __future__ import annotations

import operator
from collections.abc import Callable
from typing import Any

OPERATORS: dict[str, Callable[[Any, Any], Any]] = {
    "==": operator.eq,
    "!=": operator.ne,
    "<": operator.lt,
    "<=": operator.le,
    ">": operator.gt,
    ">=": operator.ge,
    "in": lambda lhs, rhs: lhs in rhs,  # one of a list of values
}


def comparison(op: str) -> Callable[[Any, Any], bool]:
    """The comparison `op` as a function that answers False, never raises, for incomparable values.

    Arrays compare element-wise; the comparison holds when it holds for every element.
    """
    compare = OPERATORS[op]

    def safe(lhs: Any, rhs: Any) -> bool:
        try:
            result = compare(lhs, rhs)
            return bool(result.all()) if hasattr(result, "all") else bool(result)
        except (TypeError, ValueError):
            return False

    return safe
