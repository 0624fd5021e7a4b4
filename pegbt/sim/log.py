"""The simulator's own log: every injected fault and every ground-truth world event, with its time.

Kept in memory, appended to a JSON-lines file when one is given, and handed to a publisher (the
endpoint puts each entry on `sim/events`). It is the judge of what happened, independent of what the
executive believes.
"""

from __future__ import annotations

import json
from collections.abc import Callable
from pathlib import Path
from typing import Any

from pegbt.errors import PegbtError
from pegbt.sim.events import Event


class SimLog:
    """Log entries as JSON lines: kept (`lines`, what `sim/truth` hands out), appended to a file, published."""

    def __init__(self, path: Path | None = None, publish: Callable[[str], None] | None = None) -> None:
        self.lines: list[str] = []  # each entry as one line of JSON
        try:
            self._file = None if path is None else open(path, "a", encoding="utf-8")
        except OSError as error:
            raise PegbtError(
                f"cannot write the simulator's log: {error.strerror}", file=path, field="--log"
            ) from None
        self._publish = publish

    def record(self, time: float, kind: str, **details: Any) -> None:
        """One entry: its simulated `time` (s), its `kind` (a world event's, "fault", "refused", "start"), details."""
        line = json.dumps({"time": round(time, 6), "kind": kind, **details}, default=_plain)
        self.lines.append(line)
        if self._file is not None:
            self._file.write(line + "\n")
            self._file.flush()
        if self._publish is not None:
            self._publish(line)

    def record_event(self, event: Event) -> None:
        """A world event, at its own time and with its own kind (grasp, drop, place, collision, ...)."""
        details = {name: value for name, value in event.to_dict().items() if name not in ("time", "kind")}
        self.record(event.time, event.kind, **details)

    def close(self) -> None:
        if self._file is not None:
            self._file.close()
            self._file = None


def read_sim_log(path: Path) -> list[dict[str, Any]]:
    """The entries a `SimLog` wrote to `path` (times in simulated seconds); a `PegbtError` naming the line
    of anything that is not one JSON object per line (a simulator killed mid-write, say)."""
    try:
        lines = path.read_text(encoding="utf-8").splitlines()
    except OSError as error:
        raise PegbtError(f"cannot read the simulator's log: {error.strerror}", file=path) from None
    entries = []
    for number, line in enumerate(lines, 1):
        if not line.strip():
            continue
        try:
            entry = json.loads(line)
        except json.JSONDecodeError as error:
            raise PegbtError(
                f"not a log entry: {error.msg}", file=path, line=number, column=error.colno
            ) from None
        if not isinstance(entry, dict):
            raise PegbtError("not a log entry: expected a JSON object", file=path, line=number)
        entries.append(entry)
    return entries


def _plain(value: Any) -> Any:
    """numpy scalars and arrays as plain JSON values."""
    return value.tolist() if hasattr(value, "tolist") else str(value)
