"""What `pegbt run` prints as it runs: failures, halts and recoveries as they happen (every leaf's result with
`verbose`), and `tick_bar`, the progress bar of a tree whose resources bring none of their own. A check that
steers the tree (`check_blackboard`, a handover's protocol checks) answers "no" by failing; that is not a
failure of the task, so it is printed only with `verbose`."""

from __future__ import annotations

import sys
from collections.abc import Callable
from typing import IO, Any

from rich.console import Console
from rich.progress import Progress, SpinnerColumn, TextColumn, TimeElapsedColumn

from pegbt.executive.build import BuiltTree
from pegbt.executive.causes import CONTROL_FLOW
from pegbt.executive.logfile import message_line

_FINISHED = ("SUCCESS", "FAILURE")


class ProgressPrinter:
    """A tick-log listener that prints leaf failures and halts, and each recovery as it starts."""

    def __init__(self, built: BuiltTree, stream: IO[str] | None = None, *, verbose: bool = False) -> None:
        self.stream = (
            stream or sys.stdout
        )  # looked up now, not at import: the stream may have been swapped since
        self.verbose = verbose
        self.leaves = {node.id: node.spec.path for node in built.nodes if not node.spec.children}
        self.checks = {node.id for node in built.nodes if node.spec.type in CONTROL_FLOW}
        children: dict[int, list[int]] = {}
        for node in built.nodes:
            if node.parent is not None:
                children.setdefault(node.parent, []).append(node.id)
        self.recoveries = {  # the recovery child (the second) of each `recover` node -> that node's path
            children[node.id][1]: node.spec.path for node in built.nodes if node.spec.type == "recover"
        }

    def __call__(self, record: dict[str, Any]) -> None:
        kind = record["type"]
        if kind in ("tick", "halt"):
            for node, before, after, feedback in record["changes"]:
                if node in self.recoveries and before != "RUNNING" and after != "INVALID":
                    print(f"{record['t']:8.3f} s  RECOVER  {self.recoveries[node]}", file=self.stream)
                if node in self.leaves and self._shown(kind, after, node in self.checks):
                    shown = "HALTED" if kind == "halt" else after
                    note = f"  ({feedback})" if feedback else ""
                    print(f"{record['t']:8.3f} s  {shown:<7}  {self.leaves[node]}{note}", file=self.stream)
        elif kind == "message":
            print(
                f"{record['t']:8.3f} s  {record['level'].upper():<7}  {message_line(record)}",
                file=self.stream,
            )
        elif kind == "end":
            print(
                f"{record['t']:8.3f} s  run ended: {record['outcome']} after {record['n']} ticks",
                file=self.stream,
            )

    def _shown(self, kind: str, after: str, check: bool) -> bool:
        if kind == "halt":
            return after == "INVALID"
        return after == "FAILURE" and not check or self.verbose and after in _FINISHED


def tick_bar(stream: IO[str] | None = None) -> Callable[[dict[str, Any]], None]:
    """A tick-log listener showing the tick count and the run's clock while the tree runs (on a terminal)."""
    console = Console(file=stream or sys.stdout)
    progress = Progress(
        SpinnerColumn(), TextColumn("{task.description}"), TimeElapsedColumn(), console=console
    )
    task = progress.add_task("tick 0", total=None)

    def listen(record: dict[str, Any]) -> None:
        if record["type"] == "header":
            if console.is_terminal:
                progress.start()
        elif record["type"] == "end":
            if progress.live.is_started:
                progress.stop()
        else:
            progress.update(task, description=f"tick {record['n']}, t = {record['t']:.2f} s")

    return listen
