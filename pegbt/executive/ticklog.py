"""Tick log writer: JSON Lines, one header, then one record per tick that changed something.

Records (one JSON object per line, flushed as written so that a crash loses nothing):

- `header`: format version, pegbt version, tree file, start time (wall clock, ISO 8601), the clock's
  kind, initial blackboard, and `nodes`: id, parent, path, name, type, py_trees class, source
  `file:line:column`, parameters, blackboard keys read and written, subtree instance. A run of
  `run_tree_file` adds `variant`, `condition` and `run`, its options (`RunOptions.record_fields`).
- `tick`: `n` (tick number from 1), `t` (executive-clock seconds since the start), `dt_us` (wall
  cost of the tick, for profiling), `changes` as `[id, from, to, feedback]` and `bb` as
  `{key: compact value}` (`bb_unset` lists deleted keys); `late_s` when the tick overran its period
  on the run's clock (such a tick is always written); `detail` as `{id: {...}}`: what a leaf that
  finished in the tick says beside its feedback (its `log_detail`: a carry, which segment of its motion
  was playing and whether the jaw held the block).
- `halt`: the tree was halted (`reason`: `interrupt`, `timeout`, `crash`), with the status changes the
  halt caused (running nodes going to INVALID had `terminate` called).
- `crash`: an exception escaped a tick (`error`, `traceback`).
- `end`: `outcome` (`success`, `failure`, `timeout`, `interrupted`, `crash`), `ticks`, `t`,
  `overruns` (ticks that overran the period) and `work` (jobs run off the tick: `jobs`, `compute_s`,
  `waited_s` from submission to pick-up, wall time; `by_kind`, the same per function a job ran).
- `message`: what a robot said (a CRTK robot's `error`, `warning` and `status` topics): `n` and `t` of the
  tick it was logged before, `source` (the arm), `level` (`error`, `warning`, `status`), `text`, and
  `stamp` (the run's clock when it arrived; optional: a reader takes a message without one).

A blackboard value changed in place (the same object mutated) is not seen: behaviours write new values.
A node that finishes with the same status on consecutive ticks (a condition that keeps failing, a
retried leaf failing again) is one transition: the log records changes, not every evaluation.
Status changes inside one tick are kept: `tick_logged` sees each node as py_trees yields it, so a
`recover` whose main child fails, recovers and restarts within one tick logs the failure too. Cheap by
construction: statuses are compared by identity, blackboard entries by identity (then equality), and
a line is written only when something differs.
"""

from __future__ import annotations

import datetime
import json
import operator
from collections.abc import Callable, Mapping, Sequence
from pathlib import Path
from typing import IO, Any

import py_trees

from pegbt import __version__
from pegbt.executive.build import BuiltTree
from pegbt.executive.compact import compact
from pegbt.executive.conditions import comparison
from pegbt.executive.logfile import FORMAT, FORMAT_VERSION
from pegbt.executive.params import BlackboardRef

_MISSING = object()
_same = comparison("==")
_ENCODER = json.JSONEncoder(separators=(",", ":"))
_status_of = operator.attrgetter("status")
_NAME = {status: status.value for status in py_trees.common.Status}  # Enum.value is a slow descriptor
_FINISHED = (py_trees.common.Status.SUCCESS, py_trees.common.Status.FAILURE)

Record = dict[str, Any]


def node_table(built: BuiltTree) -> list[Record]:
    """The header's description of every node, in id order."""
    table = []
    for node in built.nodes:
        spec = node.spec
        table.append(
            {
                "id": node.id,
                "parent": node.parent,
                "path": spec.path,
                "name": spec.name,
                "type": spec.type,
                "class": type(node.behaviour).__name__,
                "source": str(spec.mark),
                "params": {
                    name: str(value) if isinstance(value, BlackboardRef) else compact(value)
                    for name, value in spec.params.items()
                },
                "reads": sorted({use.key for use in spec.keys if use.access == "read"}),
                "writes": sorted({use.key for use in spec.keys if use.access == "write"}),
                "subtree": spec.subtree,
            }
        )
    return table


class TickLogWriter:
    """Writes the tick log of one run of `built`; `listeners` see every record as it is written."""

    def __init__(
        self,
        path: Path | str,
        built: BuiltTree,
        *,
        clock_kind: str,
        run: Mapping[str, Any] | None = None,
        listeners: Sequence[Callable[[Record], None]] = (),
        messages: Sequence[Callable[[], list[Record]]] = (),
    ) -> None:
        """`run`: the run's options, as `RunOptions.record_fields` gives them, added to the header;
        `messages`: sources of `message` records (each returns what arrived since it was last asked),
        drained before every tick, halt and end record."""
        self.path = Path(path)
        self.path.parent.mkdir(parents=True, exist_ok=True)
        self._file: IO[bytes] = self.path.open(
            "wb", buffering=0
        )  # unbuffered: each record is one write, nothing held back
        self._root = built.root
        self._behaviours = [node.behaviour for node in built.nodes]
        self._index = {behaviour: index for index, behaviour in enumerate(self._behaviours)}
        self._status = [behaviour.status for behaviour in self._behaviours]
        self._changes: list[list[Any]] = []
        self._details: dict[str, Any] = {}
        self._blackboard: dict[str, Any] = {}
        self._listeners = list(listeners)
        self._messages = list(messages)
        self._write(
            {
                "type": "header",
                "format": FORMAT,
                "format_version": FORMAT_VERSION,
                "pegbt": __version__,
                "tree": built.source,
                "start_time": datetime.datetime.now(datetime.UTC).isoformat(timespec="milliseconds"),
                "clock": clock_kind,
                "blackboard": {key: compact(value) for key, value in built.initial_blackboard.items()},
                **(run or {}),
                "nodes": node_table(built),
            }
        )

    def _write(self, record: Record) -> None:
        self._file.write((_ENCODER.encode(record) + "\n").encode("utf-8"))
        for listener in self._listeners:
            listener(record)

    def tick_logged(self) -> None:
        """Tick the tree once, noting each node's status as py_trees reports it during the tick."""
        index, previous, changes, name = (
            self._index,
            self._status,
            self._changes,
            _NAME,
        )  # `previous` is updated in place
        for node in self._root.tick():
            i = index[node]
            status = node.status
            if status is not previous[i]:
                changes.append([i, name[previous[i]], name[status], node.feedback_message])
                previous[i] = status
                if status in _FINISHED and (detail := getattr(node, "log_detail", None)) is not None:
                    self._details[str(i)] = compact(detail)

    def _status_changes(self) -> list[list[Any]]:
        """Changes noted during the tick, then those of nodes that changed without being ticked (halted)."""
        changes, self._changes = self._changes, []
        current = list(map(_status_of, self._behaviours))
        previous = self._status
        if current != previous:  # compares by identity first: cheap when nothing was halted
            for index, (before, after) in enumerate(zip(previous, current)):
                if before is not after:
                    changes.append(
                        [index, _NAME[before], _NAME[after], self._behaviours[index].feedback_message]
                    )
            self._status = current
        return changes

    def _blackboard_changes(self) -> tuple[dict[str, Any], list[str]]:
        storage = py_trees.blackboard.Blackboard.storage
        last = self._blackboard
        written = {}
        for key, value in storage.items():
            old = last.get(key, _MISSING)
            if old is not value:
                last[key] = value
                if old is _MISSING or not _same(old, value):
                    written[key] = compact(value)
        unset = [key for key in last if key not in storage] if len(last) > len(storage) else []
        for key in unset:
            del last[key]
        return written, unset

    def _drain_messages(self, n: int, t: float) -> None:
        for source in self._messages:
            for message in source():
                self._write({"type": "message", "n": n, "t": round(t, 6), **message})

    def tick(self, n: int, t: float, dt: float, late: float = 0.0) -> None:
        """Record tick `n` (at executive time `t`, wall cost `dt` seconds) if it changed anything or ran
        `late` seconds past its period."""
        self._drain_messages(n, t)
        changes = self._status_changes()
        written, unset = self._blackboard_changes()
        if changes or written or unset or late > 0:
            record: Record = {
                "type": "tick",
                "n": n,
                "t": round(t, 6),
                "dt_us": round(dt * 1e6, 1),
                "changes": changes,
            }
            if late > 0:
                record["late_s"] = round(late, 6)
            if self._details:
                record["detail"], self._details = self._details, {}
            if written:
                record["bb"] = written
            if unset:
                record["bb_unset"] = unset
            self._write(record)

    def halt(self, n: int, t: float, reason: str) -> None:
        """Record a halt of the tree and the status changes it caused."""
        self._drain_messages(n, t)
        self._write(
            {"type": "halt", "n": n, "t": round(t, 6), "reason": reason, "changes": self._status_changes()}
        )

    def crash(self, n: int, t: float, error: BaseException, traceback_text: str) -> None:
        self._write(
            {
                "type": "crash",
                "n": n,
                "t": round(t, 6),
                "error": f"{type(error).__name__}: {error}",
                "traceback": traceback_text,
            }
        )

    def end(
        self, n: int, t: float, outcome: str, *, overruns: int = 0, work: dict[str, Any] | None = None
    ) -> None:
        self._drain_messages(n, t)
        record: Record = {"type": "end", "n": n, "t": round(t, 6), "outcome": outcome, "overruns": overruns}
        if work is not None:
            record["work"] = work
        self._write(record)

    def close(self) -> None:
        self._file.close()
