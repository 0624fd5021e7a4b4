"""A trial's transfers, and their judgement: by the simulator's ground truth when there is one, else by
what the executive believes.

Leaves `begin_transfer` and `finish_transfer` record each transfer (arm(s), pick peg, place peg, start,
end, the executive's verdict). The judge then reads the simulator's events: a transfer succeeded when a
block lifted off its pick peg during the transfer came to rest on its place peg by the transfer's end
(plus a moment to settle): released there, or fallen there from a jaw it slipped out of (the block is
on the peg all the same); its time runs from its start to that moment. Arm-arm
collisions (tool-tool, shaft-shaft) are counted apart from other contacts (tool-peg, block-peg, block-board).
"""

from __future__ import annotations

import io
import math
import time
from collections.abc import Callable, Iterable
from dataclasses import dataclass, field
from typing import Any

from rich.console import Console, Group
from rich.progress import BarColumn, MofNCompleteColumn, Progress, TextColumn, TimeElapsedColumn
from rich.table import Table
from rich.text import Text

from pegbt.clock import Clock
from pegbt.psm import ARMS

ARM_ARM_CONTACTS = ("tool-tool", "shaft-shaft")
GRACE = 0.5  # s after a transfer's end in which its placement still counts (the block settles)


@dataclass
class TransferRecord:
    """One transfer as the executive ran it."""

    index: int
    arms: str
    pick: int
    place: int
    started: float
    ended: float | None = None
    outcome: str = "running"  # the executive's verdict: placed, skipped, failed (running: never finished)
    note: str = ""


@dataclass(frozen=True)
class TransferOutcome:
    """One transfer as judged: whether its block reached the place peg, and how long it took."""

    index: int
    arms: str
    pick: int
    place: int
    succeeded: bool
    started: float
    seconds: float | None  # from its start to its block's placement
    note: str
    ended: float | None = None  # when the executive finished it (None: never finished)


def busy_seconds(intervals: Iterable[tuple[float, float]]) -> float:
    """The union of transfers' start-to-placement intervals: transfers that overlap, two arms at once or a
    pipelined handover, count their shared time once; for one arm at a time, the sum of their times."""
    busy, reach = 0.0, -math.inf
    for start, end in sorted(intervals):
        busy += max(0.0, end - max(start, reach))
        reach = max(reach, end)
    return busy


@dataclass(frozen=True)
class TrialResult:
    """The judged trial: per-transfer outcomes and the paper's figures."""

    judged_by: str
    transfers: tuple[TransferOutcome, ...]
    trial_time_s: float
    wall_time_s: float
    arm_arm_collisions: int
    other_contacts: int
    events: dict[str, int] = field(default_factory=dict)

    @property
    def attempted(self) -> int:
        return len(self.transfers)

    @property
    def succeeded(self) -> int:
        return sum(outcome.succeeded for outcome in self.transfers)

    @property
    def transfer_times(self) -> list[float]:
        """Each successful transfer's own time, from its start to its block's placement."""
        return [
            outcome.seconds for outcome in self.transfers if outcome.succeeded and outcome.seconds is not None
        ]

    @property
    def mean_transfer_time_s(self) -> float | None:
        """Time spent transferring per successful transfer (`busy_seconds` over their number)."""
        intervals = [
            (o.started, o.started + o.seconds)
            for o in self.transfers
            if o.succeeded and o.seconds is not None
        ]
        return busy_seconds(intervals) / len(intervals) if intervals else None

    @property
    def ok(self) -> bool:
        return self.attempted > 0 and self.succeeded == self.attempted

    def as_dict(self) -> dict[str, Any]:
        """The figures as plain data (for `pegbt eval` and JSON)."""
        return {
            "judged_by": self.judged_by,
            "transfers_attempted": self.attempted,
            "transfers_succeeded": self.succeeded,
            "transfer_times_s": self.transfer_times,
            "mean_transfer_time_s": self.mean_transfer_time_s,
            "trial_time_s": self.trial_time_s,
            "wall_time_s": self.wall_time_s,
            "arm_arm_collisions": self.arm_arm_collisions,
            "other_contacts": self.other_contacts,
            "events": dict(self.events),
            "transfers": [outcome.__dict__ for outcome in self.transfers],
        }

    def summary(self) -> str:
        mean = self.mean_transfer_time_s
        return (
            f"transfers {self.succeeded}/{self.attempted} succeeded; mean transfer time "
            f"{'-' if mean is None else f'{mean:.2f} s'} (time transferring / transfers)\n"
            f"trial time {self.trial_time_s:.2f} s ({self.wall_time_s:.2f} s of wall time); "
            f"arm-arm collisions {self.arm_arm_collisions}; other contacts {self.other_contacts}"
        )

    def __rich__(self) -> Group:
        table = Table(title=f"peg transfer, judged by {self.judged_by}", title_justify="left")
        for column in ("#", "arms", "pick → place", "result", "time s", "note"):
            table.add_column(column, justify="right" if column in ("#", "time s") else "left")
        for outcome in self.transfers:
            seconds = "" if outcome.seconds is None else f"{outcome.seconds:.2f}"
            table.add_row(
                str(outcome.index),
                outcome.arms,
                f"{outcome.pick} → {outcome.place}",
                "ok" if outcome.succeeded else "FAILED",
                seconds,
                outcome.note,
            )
        return Group(table, Text(self.summary()))

    def __str__(self) -> str:
        buffer = io.StringIO()
        Console(file=buffer, width=120, color_system=None).print(self)
        return buffer.getvalue().rstrip()


def count_contacts(entries: list[dict[str, Any]]) -> tuple[int, int]:
    """Arm-arm collisions and other contacts among the simulator's log entries."""
    collisions = [entry for entry in entries if entry["kind"] == "collision"]
    arm_arm = sum(entry.get("detail") in ARM_ARM_CONTACTS for entry in collisions)
    return arm_arm, len(collisions) - arm_arm


class Trial:
    """The transfers of one run, recorded as leaves run them; `result()` judges them."""

    def __init__(self, clock: Clock, truth: Any | None = None) -> None:
        self.clock = clock
        self.truth = truth
        self.started = clock.now()
        self.wall_started = time.perf_counter()
        self.transfers: list[TransferRecord] = []

    def begin(self, arms: str, pick: int, place: int) -> TransferRecord:
        record = TransferRecord(len(self.transfers) + 1, arms, pick, place, self.clock.now())
        self.transfers.append(record)
        return record

    def under_way(self, arm: str, *, placing: bool = False) -> TransferRecord | None:
        """The transfer `arm` began last, if it has not finished: its own (`arms` the arm), or with
        `placing`, a handover in which it is the receiver (`arms` giver→arm)."""
        mine = [arm] + ([f"{other}→{arm}" for other in ARMS] if placing else [])
        record = next((r for r in reversed(self.transfers) if r.arms in mine), None)
        return record if record is not None and record.ended is None else None

    def giving(self, arm: str) -> TransferRecord | None:
        """The handover `arm` began last as its giver (`arms` arm→receiver), if it has not finished."""
        record = next((r for r in reversed(self.transfers) if r.arms.startswith(f"{arm}→")), None)
        return record if record is not None and record.ended is None else None

    def finish(self, index: int, outcome: str, note: str = "") -> TransferRecord:
        record = self.transfers[index - 1]
        record.ended, record.outcome, record.note = self.clock.now(), outcome, note
        return record

    def result(self) -> TrialResult:
        trial_time, wall_time = self.clock.now() - self.started, time.perf_counter() - self.wall_started
        if self.truth is None:
            return TrialResult(
                "the executive's beliefs (no simulator ground truth)",
                tuple(self._believed()),
                trial_time,
                wall_time,
                0,
                0,
            )
        entries = [entry for entry in self.truth.entries(self.clock) if entry["time"] >= self.started]
        kinds: dict[str, int] = {}
        for entry in entries:
            kinds[entry["kind"]] = kinds.get(entry["kind"], 0) + 1
        return TrialResult(
            "the simulator's ground truth",
            tuple(self._judged(entries)),
            trial_time,
            wall_time,
            *count_contacts(entries),
            kinds,
        )

    def _believed(self) -> list[TransferOutcome]:
        return [
            TransferOutcome(
                record.index,
                record.arms,
                record.pick,
                record.place,
                record.outcome == "placed",
                record.started,
                None if record.ended is None else record.ended - record.started,
                record.note or record.outcome,
                record.ended,
            )
            for record in self.transfers
        ]

    def _judged(self, entries: list[dict[str, Any]]) -> list[TransferOutcome]:
        outcomes = []
        for record in self.transfers:
            until = (record.ended if record.ended is not None else self.clock.now()) + GRACE
            lifted = {
                entry["block"]
                for entry in entries
                if entry["kind"] == "lift"
                and entry.get("peg") == record.pick
                and record.started <= entry["time"] <= until
            }
            placed = [
                entry
                for entry in entries
                if entry["kind"] in ("place", "drop")
                and entry.get("peg") == record.place
                and entry.get("block") in lifted
                and record.started <= entry["time"] <= until
            ]
            why = record.note or (
                "no block lifted off the pick peg" if not lifted else "not placed on the place peg"
            )
            outcomes.append(
                TransferOutcome(
                    record.index,
                    record.arms,
                    record.pick,
                    record.place,
                    bool(placed),
                    record.started,
                    placed[0]["time"] - record.started if placed else None,
                    record.note if placed else why,
                    record.ended,
                )
            )
        return outcomes

    def progress_listener(self) -> Callable[[dict[str, Any]], None]:
        """A tick-log listener drawing a progress bar of finished transfers (total: the tree's `begin_transfer` leaves)."""
        progress = Progress(
            TextColumn("{task.description}"), BarColumn(), MofNCompleteColumn(), TimeElapsedColumn()
        )
        state: dict[str, Any] = {}

        def listen(record: dict[str, Any]) -> None:
            if record["type"] == "header":
                total = sum(1 for node in record["nodes"] if node["type"] == "begin_transfer")
                if total:  # a tree that moves no block (a calibration walk) gets no bar
                    state["task"] = progress.add_task("transfers", total=total)
                    progress.start()
            elif record["type"] == "end":
                if "task" in state:
                    progress.stop()
            elif "task" in state:
                done = sum(1 for transfer in self.transfers if transfer.ended is not None)
                current = next((t for t in reversed(self.transfers) if t.ended is None), None)
                label = (
                    f"transfers ({current.arms} {current.pick}→{current.place})" if current else "transfers"
                )
                progress.update(state["task"], completed=done, description=label)

        return listen
