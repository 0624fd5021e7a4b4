"""What the monitor keeps of a run for a page that connects late: bounded for a live run, whole for a replay.

A live run may tick for hours; every page that connects gets a snapshot, not every tick: the tree (the
`header`), the run's `mode`, `scene` and `causes`, the state of every node and the blackboard before the
window (`snapshot`: as `pegbt log replay` would show it after that tick), the first and the last failure
of every node that failed before the window (the page's first failure and failure strip), the world as it
was then (the latest sample of each kind), then the last `window` tick-log records and `world_window`
world samples as they came. Everything kept is bounded by the tree's size and the two windows, so the
memory does not grow with the run's length. A replay (`window=None`) keeps every message: it is the log
file, already in memory, and the page steps through all of it.
"""

from __future__ import annotations

import json
from collections import deque
from typing import Any

EVENTS = ("tick", "halt", "crash", "end")  # the tick log's records after its header, in tick order
KEPT = ("mode", "header", "scene", "causes")  # the latest of each is all a page needs
WORLD_KINDS = ("tools", "cloud", "blocks", "truth")  # what the page draws: the latest of each
WINDOW = 500  # tick-log records sent as they came to a late page (10 s of a 50 Hz run)
WORLD_WINDOW = 50  # world samples sent as they came (5 s at the sampler's 10 Hz)

Message = dict[str, Any]


class History:
    """The messages a page that connects now is sent first; `add` takes each message as it is published."""

    def __init__(self, window: int | None = WINDOW, world_window: int | None = WORLD_WINDOW) -> None:
        self._kept: dict[str, str] = {}
        self._events: deque[tuple[Message, str]] = deque()
        self._worlds: deque[tuple[Message, str]] = deque()
        self._window = window
        self._world_window = world_window
        self._base: Message | None = None  # the state after the records that left the window
        self._failures: dict[int, list[list[Any]]] = {}  # node -> [first, last] as [node, n, t, feedback]
        self._base_world: Message | None = None
        self._initial: Message | None = None  # the state before the first record (from the header)

    @classmethod
    def whole(cls) -> History:
        """A replay's history: every message, for a page that steps through all of it."""
        return cls(window=None, world_window=None)

    def add(self, message: Message, text: str) -> None:
        kind = message.get("type")
        if kind in KEPT:
            if kind == "header":
                self._reset(message)
            self._kept[str(kind)] = text
        elif kind in EVENTS:
            self._events.append((message, text))
            if self._window is not None and len(self._events) > self._window:
                self._forget(self._events.popleft()[0])
        elif kind == "world":
            self._worlds.append((message, text))
            if self._world_window is not None and len(self._worlds) > self._world_window:
                self._forget_world(self._worlds.popleft()[0])

    def snapshot(self) -> list[str]:
        """The JSON texts a new page gets, in the order the page needs them."""
        texts = [self._kept[kind] for kind in ("mode", "header") if kind in self._kept]
        if self._base is not None:
            failures = [record for pair in self._failures.values() for record in pair]
            texts.append(_json({**self._base, "failures": sorted(failures, key=lambda f: f[1])}))
        texts += [text for _, text in self._events]
        texts += [self._kept[kind] for kind in ("causes", "scene") if kind in self._kept]
        if self._base_world is not None:
            texts.append(_json(self._base_world))
        texts += [text for _, text in self._worlds]
        return texts

    def _reset(self, header: Message) -> None:
        self._events.clear()
        self._worlds.clear()
        self._failures.clear()
        self._base_world = None
        nodes = header.get("nodes") or []
        self._base = None
        self._initial = {
            "type": "snapshot",
            "n": 0,
            "t": 0.0,
            "status": ["INVALID"] * len(nodes),
            "feedback": [""] * len(nodes),
            "blackboard": dict(header.get("blackboard") or {}),
        }

    def _forget(self, event: Message) -> None:
        """Fold a record that leaves the window into the state before the window."""
        if self._base is None:
            if self._initial is None:  # records without a header: no tree to show them on
                return
            initial = self._initial
            self._base = {
                **initial,
                "status": list(initial["status"]),
                "feedback": list(initial["feedback"]),
                "blackboard": dict(initial["blackboard"]),
            }
        base = self._base
        base["n"], base["t"] = event.get("n", base["n"]), event.get("t", base["t"])
        status, feedback = base["status"], base["feedback"]
        for change in event.get("changes") or ():
            node, _, after, text = change
            if not (isinstance(node, int) and 0 <= node < len(status)):
                continue
            status[node], feedback[node] = after, text
            if after == "FAILURE":
                failure = [node, base["n"], base["t"], text]
                if node in self._failures:
                    self._failures[node][1:] = [failure]
                else:
                    self._failures[node] = [failure]
        base["blackboard"].update(event.get("bb") or {})
        for key in event.get("bb_unset") or ():
            base["blackboard"].pop(key, None)

    def _forget_world(self, sample: Message) -> None:
        merged = self._base_world or {"type": "world"}
        merged["n"], merged["t"] = sample.get("n"), sample.get("t")
        for kind in WORLD_KINDS:
            if kind in sample:
                merged[kind] = sample[kind]
        self._base_world = merged


def _json(message: Message) -> str:
    return json.dumps(message, separators=(",", ":"))
