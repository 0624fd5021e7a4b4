"""Traced memory of one action, for tests that compare a peak at two lengths."""

from __future__ import annotations

import tracemalloc
from collections.abc import Callable
from typing import Any


def peak_bytes(action: Callable[[], Any]) -> tuple[int, Any]:
    """(peak traced bytes while `action` ran, its result)."""
    tracemalloc.start()
    try:
        result = action()
        return tracemalloc.get_traced_memory()[1], result
    finally:
        tracemalloc.stop()
