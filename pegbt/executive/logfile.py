"""Reading tick logs back: every record checked, every problem reported with its line number."""

from __future__ import annotations

import json
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from pegbt.errors import PegbtError
from pegbt.executive.ticklog import FORMAT, FORMAT_VERSION

STATUSES = ("INVALID", "RUNNING", "SUCCESS", "FAILURE")
_EVENT_TYPES = ("tick", "halt", "crash", "end", "message")


@dataclass(frozen=True)
class Transition:
    """One status change: where it sits in the run (`seq` orders changes within a tick too)."""

    seq: int
    n: int
    t: float
    node: int
    before: str
    after: str
    feedback: str
    halted: str | None = None  # the halt reason when a halt caused it


@dataclass
class TickLog:
    """A parsed tick log: header, nodes, status transitions in order, blackboard writes, and how it ended."""

    path: Path
    header: dict[str, Any]
    nodes: list[dict[str, Any]]
    transitions: list[Transition] = field(default_factory=list)
    writes: list[tuple[int, float, str, Any]] = field(
        default_factory=list
    )  # (n, t, key, value); None value = unset
    crash: dict[str, Any] | None = None
    end: dict[str, Any] | None = None
    messages: list[dict[str, Any]] = field(default_factory=list)  # what robots said (`message` records)
    last_n: int = 0
    last_t: float = 0.0

    @property
    def outcome(self) -> str:
        return (
            self.end["outcome"]
            if self.end
            else "unfinished (no end record: the run was killed or is still running)"
        )

    def children(self, node: int) -> list[int]:
        return [other["id"] for other in self.nodes if other["parent"] == node]

    def depth(self, node: int) -> int:
        depth, parent = 0, self.nodes[node]["parent"]
        while parent is not None:
            depth, parent = depth + 1, self.nodes[parent]["parent"]
        return depth

    def blackboard_at(self, n: int) -> dict[str, Any]:
        """Blackboard values after tick `n` (initial values, then every logged write up to it)."""
        values = dict(self.header.get("blackboard", {}))
        for tick, _, key, value in self.writes:
            if tick > n:
                break
            if value is _UNSET:
                values.pop(key, None)
            else:
                values[key] = value
        return values


_UNSET = object()


def read_tick_log(path: str | Path) -> TickLog:
    """Parse and check a tick log; a `PegbtError` naming the line and field for anything malformed."""
    path = Path(path)
    try:
        data = path.read_bytes()
    except FileNotFoundError:
        raise PegbtError("tick log not found", file=path) from None
    except OSError as error:
        raise PegbtError(f"cannot read: {error.strerror}", file=path) from None
    if not data.strip():
        raise PegbtError("the tick log is empty", file=path, line=1)
    lines = data.split(b"\n")
    if lines[-1] == b"":
        lines.pop()
    log: TickLog | None = None
    for number, raw in enumerate(lines, start=1):
        record = _parse_line(raw, number, path, last=number == len(lines) and not data.endswith(b"\n"))
        if log is None:
            log = _header(record, path)
            continue
        _event(log, record, number, path)
    return log


def _parse_line(raw: bytes, number: int, path: Path, last: bool) -> dict[str, Any]:
    try:
        record = json.loads(raw)
    except (json.JSONDecodeError, UnicodeDecodeError) as error:
        if last:
            raise PegbtError(
                "truncated record: the log ends in the middle of a line (was the run killed while writing?)",
                file=path,
                line=number,
            ) from None
        column = getattr(error, "colno", None)
        raise PegbtError(
            f"corrupt record: not JSON ({getattr(error, 'msg', error)})",
            file=path,
            line=number,
            column=column,
        ) from None
    if not isinstance(record, dict):
        raise PegbtError("corrupt record: expected a JSON object", file=path, line=number)
    return record


def _require(record: dict[str, Any], key: str, kind: type | tuple[type, ...], path: Path, line: int) -> Any:
    value = record.get(key)
    if not isinstance(value, kind) or isinstance(value, bool) and kind is not bool:
        raise PegbtError(
            f"corrupt record: expected {getattr(kind, '__name__', kind)}, found {value!r}",
            file=path,
            line=line,
            field=key,
        )
    return value


def _header(record: dict[str, Any], path: Path) -> TickLog:
    if record.get("type") != "header" or record.get("format") != FORMAT:
        raise PegbtError(
            f"not a pegbt tick log: the first record should be a {FORMAT} header",
            file=path,
            line=1,
            field="type",
        )
    if record.get("format_version") != FORMAT_VERSION:
        raise PegbtError(
            f"tick log format version {record.get('format_version')!r}; this pegbt reads version {FORMAT_VERSION}",
            file=path,
            line=1,
            field="format_version",
        )
    nodes = _require(record, "nodes", list, path, 1)
    for index, node in enumerate(nodes):
        if not isinstance(node, dict) or node.get("id") != index or not isinstance(node.get("path"), str):
            raise PegbtError(f"corrupt node table entry {index}", file=path, line=1, field="nodes")
        parent = node.get("parent")
        if parent is not None and not (isinstance(parent, int) and 0 <= parent < index):
            raise PegbtError(f"node {index} has a bad parent {parent!r}", file=path, line=1, field="nodes")
    if not isinstance(record.get("blackboard", {}), dict):
        raise PegbtError("corrupt record: expected a mapping", file=path, line=1, field="blackboard")
    return TickLog(path=path, header=record, nodes=nodes)


def _event(log: TickLog, record: dict[str, Any], line: int, path: Path) -> None:
    kind = record.get("type")
    if kind not in _EVENT_TYPES:
        raise PegbtError(
            f"unknown record type {kind!r}; expected one of {', '.join(_EVENT_TYPES)}",
            file=path,
            line=line,
            field="type",
        )
    if log.end is not None:
        raise PegbtError("record after the end record", file=path, line=line, field="type")
    n = _require(record, "n", int, path, line)
    t = float(_require(record, "t", (int, float), path, line))
    if n < log.last_n:
        raise PegbtError(f"tick {n} comes after tick {log.last_n}", file=path, line=line, field="n")
    log.last_n, log.last_t = n, t
    if kind == "end":
        _require(record, "outcome", str, path, line)
        log.end = record
        return
    if kind == "crash":
        log.crash = record
        return
    if kind == "message":
        for key in ("source", "level", "text"):
            _require(record, key, str, path, line)
        log.messages.append(record)
        return
    halted = record.get("reason") if kind == "halt" else None
    for change in _require(record, "changes", list, path, line):
        log.transitions.append(_transition(log, change, n, t, halted, path, line))
    for key, value in (record.get("bb") or {}).items():
        log.writes.append((n, t, key, value))
    for key in record.get("bb_unset") or []:
        log.writes.append((n, t, key, _UNSET))


def _transition(
    log: TickLog, change: Any, n: int, t: float, halted: str | None, path: Path, line: int
) -> Transition:
    valid = (
        isinstance(change, list)
        and len(change) == 4
        and isinstance(change[0], int)
        and 0 <= change[0] < len(log.nodes)
        and change[1] in STATUSES
        and change[2] in STATUSES
        and isinstance(change[3], str)
    )
    if not valid:
        raise PegbtError(
            f"corrupt status change {change!r}: expected [node id, from, to, feedback]",
            file=path,
            line=line,
            field="changes",
        )
    return Transition(len(log.transitions), n, t, change[0], change[1], change[2], change[3], halted)
