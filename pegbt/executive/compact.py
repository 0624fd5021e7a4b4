"""Compact, JSON-safe renderings of blackboard values for tick logs (arrays become short lists)."""

from __future__ import annotations

import enum
from typing import Any

MAX_ITEMS = 16
MAX_TEXT = 200


def compact(value: Any, depth: int = 0) -> Any:
    """`value` as JSON-ready data: numbers, strings, short lists and dicts; anything else as a short repr."""
    if value is None or isinstance(value, (bool, int, float, str)):
        return value if not isinstance(value, str) or len(value) <= MAX_TEXT else value[:MAX_TEXT] + "..."
    if isinstance(value, enum.Enum):
        return str(value.value)
    if depth < 3 and hasattr(value, "shape") and hasattr(value, "tolist"):
        return _array(value)
    if depth < 3 and isinstance(value, (list, tuple)):
        items = [compact(item, depth + 1) for item in value[:MAX_ITEMS]]
        return items if len(value) <= MAX_ITEMS else {"len": len(value), "head": items}
    if depth < 3 and isinstance(value, dict):
        return {str(key): compact(item, depth + 1) for key, item in list(value.items())[:MAX_ITEMS]}
    text = repr(value)
    return {"repr": text if len(text) <= MAX_TEXT else text[:MAX_TEXT] + "..."}


def _array(array: Any) -> Any:
    if array.ndim == 0:
        return array.item()
    if array.size <= MAX_ITEMS:
        return array.tolist()
    return {"shape": list(array.shape), "dtype": str(array.dtype), "head": array.ravel()[:8].tolist()}
