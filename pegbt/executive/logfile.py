"""Reading tick logs back: every record checked, every problem reported with its line number.

The reader is total: the file's size is bounded before it is read, every field the analyses use is
checked (type, range, finiteness), the node table's depth is bounded, and its questions (children,
depth) are answered from tables built once, so a log of a 20,000-node tree reads in linear time. A log
cut short by a crash is read up to its last complete record, and `TickLog.warnings` says what was cut;
a record repeated verbatim (a writer retrying a line) is read once, with a warning.
"""

from __future__ import annotations

import datetime
import json
import math
import sys
from dataclasses import dataclass, field, replace
from functools import cached_property
from pathlib import Path
from typing import Any

from pegbt.boundedio import read_bytes
from pegbt.errors import PegbtError, brief
from pegbt.executive.spec import MAX_TREE_DEPTH
from pegbt.runconditions import PROTOCOLS

FORMAT = "pegbt-ticklog"  # what the writer (`pegbt.executive.ticklog`) puts in the header, and this reads
FORMAT_VERSION = 1
STATUSES = ("INVALID", "RUNNING", "SUCCESS", "FAILURE")
_DONE = ("SUCCESS", "FAILURE")
_EVENT_TYPES = ("tick", "halt", "crash", "end", "message")
MAX_LOG_BYTES = 512 * 2**20
MAX_TICK = 2**53  # ticks are counted exactly in a float too
MAX_TIME = 1e9  # s of executive time: 31 years
_NODE_TEXT = ("path", "name", "type", "source")
# the other files a run leaves beside its tick log, by their first bytes (MCAP's magic, FileLogger2's)
_OTHER_FORMATS = {
    b"\x89MCAP0\r\n": "an MCAP recording (`--record`): read it with an MCAP tool or `pegbt sim2real diagnose`",
    b"BTCPP4-FileLogger2": "a BT.CPP FileLogger2 .btlog (`pegbt log export`): open it in Groot2",
}
_NODE_KEYS = ("reads", "writes")
# header fields that may be missing (older logs, logs not written by `run_tree_file`), and their types if present
_HEADER_FIELDS: dict[str, tuple[type, ...]] = {
    "blackboard": (dict,),
    "tree": (str, type(None)),
    "variant": (str,),
    "condition": (str, type(None)),
    "run": (dict,),
}
_TYPE_NAMES: dict[type, str] = {dict: "a mapping", str: "a string"}


class TickLogError(PegbtError):
    """A tick log that cannot be read: the file, line and field at fault."""


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
    detail: dict[str, Any] | None = (
        None  # what the leaf said beside its feedback as it finished (`log_detail`)
    )


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
    warnings: list[str] = field(default_factory=list)  # what was skipped or cut while reading
    records: list[dict[str, Any]] | None = None  # every record read, header first (`keep_records`)

    @property
    def variant(self) -> str:
        """The task variant the header names; for a log written before headers named it, the tree file's name."""
        return self.header.get("variant") or Path(str(self.header.get("tree", ""))).stem

    @property
    def condition(self) -> str | None:
        """The skills' condition the run had (None: not recorded, a log from before headers named it)."""
        return self.header.get("condition")

    @property
    def protocol(self) -> str:
        """The protocol the run followed (`--protocol`): pegbt's for a log from before headers recorded it;
        one that names no known protocol is refused, never counted as another protocol's."""
        options = self.run.get("options") or {}
        protocol = (options.get("protocol") or "pegbt") if isinstance(options, dict) else options
        if protocol not in PROTOCOLS:
            raise TickLogError(
                f"its header names protocol {protocol!r}; expected one of {', '.join(PROTOCOLS)}",
                file=self.path,
                line=1,
                field="run.options.protocol",
            )
        return str(protocol)

    @property
    def run(self) -> dict[str, Any]:
        """The run's options as the header records them (`RunOptions.record_fields`); empty if it has none."""
        return self.header.get("run") or {}

    @property
    def outcome(self) -> str:
        return (
            self.end["outcome"]
            if self.end
            else "unfinished (no end record: the run was killed or is still running)"
        )

    def children(self, node: int) -> list[int]:
        return self._children[node]

    def depth(self, node: int) -> int:
        return self._depths[node]

    @cached_property
    def _children(self) -> list[list[int]]:
        children: list[list[int]] = [[] for _ in self.nodes]
        for node in self.nodes:
            if node["parent"] is not None:
                children[node["parent"]].append(node["id"])
        return children

    @cached_property
    def _depths(self) -> list[int]:
        return _depths(self.nodes)

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


def message_line(message: dict[str, Any]) -> str:
    """A `message` record's `source: text`, the source not repeated where the text opens with it (the dVRK
    starts its messages with the arm's name: `mtsIntuitiveResearchKitArm.cpp`, `SendError(GetName() + ...)`);
    a message the robot had sent before the run (a latched topic's history) says so."""
    source, text = str(message["source"]), str(message["text"])
    line = text if text.startswith(f"{source}: ") else f"{source}: {text}"
    return f"{line} (before this run)" if message.get("before_run") else line


def read_tick_log(path: str | Path, *, keep_records: bool = False) -> TickLog:
    """Parse and check a tick log; a `TickLogError` naming the line and field for anything malformed.

    A last line cut short (the run died while writing it) is left out, with a warning in `warnings`.
    `keep_records` keeps the records read in `records` (the monitor replays them as they are)."""
    path = Path(path)
    try:
        data = read_bytes(path, MAX_LOG_BYTES, "tick log")
    except TickLogError:
        raise
    except PegbtError as error:
        raise TickLogError(error.message, file=path) from None
    if not data.strip():
        raise TickLogError("the tick log is empty", file=path, line=1)
    for magic, what in _OTHER_FORMATS.items():
        if data.startswith(magic):
            raise TickLogError(f"not a tick log: this is {what}", file=path, line=1)
    lines = data.split(b"\n")
    cut = lines.pop()  # after the last newline: empty, or a record the writer never finished
    log: TickLog | None = None
    previous = b""
    for number, raw in enumerate(lines, start=1):
        record = _parse_line(raw, number, path)
        if log is None:
            log = _header(record, path)
            log.records = [record] if keep_records else None
        elif raw == previous and record.get("type") in ("tick", "halt"):
            log.warnings.append(f"line {number} repeats line {number - 1} word for word; read once")
        else:
            _event(log, record, number, path)
            if log.records is not None:
                log.records.append(record)
        previous = raw
    if cut.strip():
        if log is None:
            raise TickLogError(
                "truncated record: the log ends in the middle of its header (was the run killed while writing?)",
                file=path,
                line=len(lines) + 1,
            )
        log.warnings.append(
            f"line {len(lines) + 1} was cut short ({len(cut)} bytes, no newline: the run died while writing it); "
            f"read up to line {len(lines)}, tick {log.last_n}"
        )
    assert log is not None  # the file is not blank, so it has a first line, or a cut one refused above
    return log


def read_log_warning(path: str | Path, *, keep_records: bool = False) -> TickLog:
    """`read_tick_log` for a command: what the reader skipped or cut (a crash's last line, a repeat) is said
    on stderr, where the user sees it beside the command's output."""
    log = read_tick_log(path, keep_records=keep_records)
    for warning in log.warnings:
        print(f"pegbt: warning: {path}: {warning}", file=sys.stderr)
    return log


def _parse_line(raw: bytes, number: int, path: Path) -> dict[str, Any]:
    try:
        record = json.loads(raw)
    except (ValueError, UnicodeDecodeError, RecursionError) as error:
        if isinstance(error, RecursionError):
            reason = "nested too deeply"
        elif isinstance(error, json.JSONDecodeError):
            reason = error.msg
        else:
            reason = str(error).split(";")[0]  # an integer too long to convert, say
        raise TickLogError(
            f"corrupt record: not JSON ({reason})",
            file=path,
            line=number,
            column=getattr(error, "colno", None),
        ) from None
    if not isinstance(record, dict):
        raise TickLogError("corrupt record: expected a JSON object", file=path, line=number)
    return record


def _require(record: dict[str, Any], key: str, kind: type | tuple[type, ...], path: Path, line: int) -> Any:
    value = record.get(key)
    if not isinstance(value, kind) or isinstance(value, bool) and kind is not bool:
        raise TickLogError(
            f"corrupt record: expected {getattr(kind, '__name__', kind)}, found {brief(value)}",
            file=path,
            line=line,
            field=key,
        )
    return value


def _header(record: dict[str, Any], path: Path) -> TickLog:
    if record.get("type") != "header" or record.get("format") != FORMAT:
        raise TickLogError(
            f"not a pegbt tick log: the first record should be a {FORMAT} header",
            file=path,
            line=1,
            field="type",
        )
    if record.get("format_version") != FORMAT_VERSION:
        raise TickLogError(
            f"tick log format version {record.get('format_version')!r}; this pegbt reads version {FORMAT_VERSION}",
            file=path,
            line=1,
            field="format_version",
        )
    nodes = _require(record, "nodes", list, path, 1)
    if not nodes:
        raise TickLogError("the node table is empty", file=path, line=1, field="nodes")
    for index, node in enumerate(nodes):
        _check_node(node, index, path)
    depths = _depths(nodes)
    if depths and max(depths) > MAX_TREE_DEPTH:
        deepest = next(index for index, depth in enumerate(depths) if depth > MAX_TREE_DEPTH)
        raise TickLogError(
            f"node {deepest} is nested {depths[deepest]} levels deep; trees are at most {MAX_TREE_DEPTH}",
            file=path,
            line=1,
            field="nodes",
        )
    for key, kinds in _HEADER_FIELDS.items():
        if key in record and not isinstance(record[key], kinds):
            names = " or ".join("null" if kind is type(None) else _TYPE_NAMES[kind] for kind in kinds)
            raise TickLogError(
                f"corrupt record: expected {names}, found {brief(record.get(key))}",
                file=path,
                line=1,
                field=key,
            )
    start = record.get("start_time", "1970-01-01T00:00:00+00:00")
    try:
        datetime.datetime.fromisoformat(start).timestamp()
    except (TypeError, ValueError, OverflowError, OSError):
        raise TickLogError(
            f"expected an ISO 8601 start time, found {brief(start)}", file=path, line=1, field="start_time"
        ) from None
    return TickLog(path=path, header=record, nodes=nodes)


def _check_node(node: Any, index: int, path: Path) -> None:
    """A node table entry as the analyses use it: id, parent (an earlier node; null for the root, node 0,
    alone), texts, keys (absent ones read as none)."""
    where = f"nodes[{index}]"
    if not isinstance(node, dict) or node.get("id") != index:
        raise TickLogError(
            f"corrupt node table entry {index}: expected id {index}", file=path, line=1, field=where
        )
    if "parent" not in node:
        raise TickLogError(f"node {index} has no parent field", file=path, line=1, field=f"{where}.parent")
    parent = node["parent"]
    if (parent is None) != (index == 0) or not (
        parent is None or isinstance(parent, int) and not isinstance(parent, bool) and 0 <= parent < index
    ):
        raise TickLogError(
            f"node {index} has a bad parent {brief(parent)}", file=path, line=1, field=f"{where}.parent"
        )
    for name in _NODE_TEXT:
        if not isinstance(node.get(name), str):
            raise TickLogError(f"node {index}: expected a string", file=path, line=1, field=f"{where}.{name}")
    for name in _NODE_KEYS:
        keys = node.setdefault(name, [])
        if not isinstance(keys, list) or not all(isinstance(key, str) for key in keys):
            raise TickLogError(
                f"node {index}: expected a list of keys", file=path, line=1, field=f"{where}.{name}"
            )
    if not isinstance(node.get("params", {}), dict):
        raise TickLogError(f"node {index}: expected a mapping", file=path, line=1, field=f"{where}.params")


def _depths(nodes: list[dict[str, Any]]) -> list[int]:
    """Each node's depth, in one pass: a parent always comes before its children."""
    depths: list[int] = []
    for node in nodes:
        depths.append(0 if node["parent"] is None else depths[node["parent"]] + 1)
    return depths


def _event(log: TickLog, record: dict[str, Any], line: int, path: Path) -> None:
    kind = record.get("type")
    if kind not in _EVENT_TYPES:
        raise TickLogError(
            f"unknown record type {kind!r}; expected one of {', '.join(_EVENT_TYPES)}",
            file=path,
            line=line,
            field="type",
        )
    if log.end is not None:
        raise TickLogError("record after the end record", file=path, line=line, field="type")
    n = _require(record, "n", int, path, line)
    t = float(_require(record, "t", (int, float), path, line))
    if not 0 <= n <= MAX_TICK:
        raise TickLogError(f"tick number {brief(n)} is outside [0, 2**53]", file=path, line=line, field="n")
    if not (math.isfinite(t) and 0 <= t <= MAX_TIME):
        raise TickLogError(
            f"time {t!r} s is not a finite time in [0, {MAX_TIME:g}] s", file=path, line=line, field="t"
        )
    if n < log.last_n:
        raise TickLogError(f"tick {n} comes after tick {log.last_n}", file=path, line=line, field="n")
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
    details = _details(log, record, path, line)
    first = len(log.transitions)
    for change in _require(record, "changes", list, path, line):
        log.transitions.append(_transition(log, change, n, t, halted, path, line))
    for node, detail in details.items():  # on the node's last finish in this record
        mine = (c for c in reversed(log.transitions[first:]) if c.node == node and c.after in _DONE)
        change = next(mine, None)
        if change is not None:
            log.transitions[change.seq] = replace(change, detail=detail)
    written = record.get("bb") or {}
    if not isinstance(written, dict):
        raise TickLogError(
            f"corrupt record: expected a mapping of blackboard keys, found {brief(written)}",
            file=path,
            line=line,
            field="bb",
        )
    unset = record.get("bb_unset") or []
    if not isinstance(unset, list) or not all(isinstance(key, str) for key in unset):
        raise TickLogError("corrupt record: expected a list of keys", file=path, line=line, field="bb_unset")
    for key, value in written.items():
        log.writes.append((n, t, key, value))
    for key in unset:
        log.writes.append((n, t, key, _UNSET))


def _details(log: TickLog, record: dict[str, Any], path: Path, line: int) -> dict[int, dict[str, Any]]:
    """A tick's `detail` record: {node id: mapping}, checked."""
    details = record.get("detail") or {}
    valid = isinstance(details, dict) and all(
        key.isdigit() and int(key) < len(log.nodes) and isinstance(value, dict)
        for key, value in details.items()
    )
    if not valid:
        raise TickLogError(
            f"corrupt record: expected a mapping of node ids to mappings, found {brief(details)}",
            file=path,
            line=line,
            field="detail",
        )
    return {int(key): value for key, value in details.items()}


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
        raise TickLogError(
            f"corrupt status change {brief(change)}: expected [node id, from, to, feedback]",
            file=path,
            line=line,
            field="changes",
        )
    return Transition(len(log.transitions), n, t, change[0], change[1], change[2], change[3], halted)
