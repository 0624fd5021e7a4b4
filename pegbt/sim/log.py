"""The simulator's own log: every injected fault and every ground-truth world event, with its time.

Kept in memory, appended to a JSON-lines file when one is given, and handed to a publisher (the
endpoint puts each entry on `sim/events`). It is the judge of what happened, independent of what the
executive believes.
"""

from __future__ import annotations

import json
from collections.abc import Callable, Mapping
from pathlib import Path
from typing import Any


class SimLog:
    def __init__(self, path: Path | None = None, publish: Callable[[str], None] | None = None) -> None:
        self.entries: list[dict[str, Any]] = []
        self._file = None if path is None else open(path, "a", encoding="utf-8")
        self._publish = publish

    def record(self, time: float, kind: str, **details: Any) -> None:
        entry = {"time": round(time, 6), "kind": kind, **details}
        self.entries.append(entry)
        line = json.dumps(entry, default=_plain)
        if self._file is not None:
            self._file.write(line + "\n")
            self._file.flush()
        if self._publish is not None:
            self._publish(line)

    def record_event(self, time: float, event: Mapping[str, Any]) -> None:
        """A world event; its own `kind` (grasp, drop, place, collision...) is kept."""
        details = dict(event)
        self.record(time, str(details.pop("kind", "world_event")), **details)

    def close(self) -> None:
        if self._file is not None:
            self._file.close()
            self._file = None


def _plain(value: Any) -> Any:
    """numpy scalars and arrays as plain JSON values."""
    return value.tolist() if hasattr(value, "tolist") else str(value)
