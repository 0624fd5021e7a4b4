"""Ground-truth events of the simulated world: the judge of success, independent of the executive.

Every grasp, release, slip, lift off a peg, placement, drop, collision and injected fault becomes one
`Event`. The log keeps them in order and writes them as JSON lines (one event per line), so a trial's
outcome can be read back and scored without trusting what the executive believed.
"""

from __future__ import annotations

import json
from collections.abc import Iterator
from dataclasses import asdict, dataclass
from pathlib import Path

from pegbt.errors import PegbtError

EVENT_KINDS = (
    "grasp",  # a closing jaw gripped a block
    "grasp_miss",  # a closing jaw near a block gripped nothing (detail says why)
    "release",  # an opening jaw let go of a block
    "slip",  # a block left a closed jaw (pulled apart in a handover, or an injected fault)
    "drag",  # a block held by two jaws slid through one still squeezing it (the other moved it)
    "lift",  # a held block's hole cleared the top of its peg
    "place",  # a released block came to rest around a peg
    "drop",  # a block fell other than by a deliberate placement: onto the board, a peg, or off the workspace
    "collision",  # contact began: tool-peg, block-peg, block-board, tool-tool, shaft-shaft
    "fault",  # an injected fault (the consequence follows as its own event)
)


@dataclass(frozen=True)
class Event:
    """One thing that happened, at simulated `time` (s). Two-arm events name both arms as "PSM1+PSM2"."""

    time: float
    kind: str
    arm: str | None = None
    block: int | None = None
    peg: int | None = None
    detail: str = ""
    parts: str = ""  # a tool-tool contact's parts that touched: "PSM1 jaw on PSM2 wrist"

    def to_dict(self) -> dict[str, float | int | str | None]:
        """The event's fields, `parts` only where it names some."""
        entry = asdict(self)
        if not self.parts:
            del entry["parts"]
        return entry


class EventLog:
    """Events in the order they happened."""

    def __init__(self) -> None:
        self._events: list[Event] = []

    def append(self, event: Event) -> None:
        if event.kind not in EVENT_KINDS:
            raise ValueError(f"unknown event kind {event.kind!r}")
        self._events.append(event)

    def __iter__(self) -> Iterator[Event]:
        return iter(self._events)

    def __len__(self) -> int:
        return len(self._events)

    def __getitem__(self, index: int) -> Event:
        return self._events[index]

    def of_kind(self, *kinds: str) -> list[Event]:
        return [event for event in self._events if event.kind in kinds]

    def since(self, index: int) -> list[Event]:
        """Events appended after the first `index` ones."""
        return self._events[index:]

    def to_dicts(self) -> list[dict[str, float | int | str | None]]:
        return [event.to_dict() for event in self._events]

    def write(self, path: Path | str) -> None:
        """Write the log as JSON lines."""
        with open(path, "w") as file:
            for event in self._events:
                file.write(json.dumps(event.to_dict()) + "\n")


def read_events(path: Path | str) -> list[Event]:
    """Events from a JSON-lines file written by `EventLog.write`."""
    events = []
    try:
        lines = Path(path).read_text().splitlines()
    except OSError as error:
        raise PegbtError(f"cannot read the event log: {error.strerror}", file=path) from None
    for number, line in enumerate(lines, 1):
        try:
            event = Event(**json.loads(line))
        except (json.JSONDecodeError, TypeError) as error:
            raise PegbtError(f"not an event: {error}", file=path, line=number) from None
        if event.kind not in EVENT_KINDS:
            raise PegbtError(f"unknown event kind {event.kind!r}", file=path, line=number, field="kind")
        events.append(event)
    return events
