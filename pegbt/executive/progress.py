"""Progress lines for `pegbt run`: each leaf that finishes or is halted, with time and feedback."""

from __future__ import annotations

import sys
from typing import IO, Any

from pegbt.executive.build import BuiltTree


class ProgressPrinter:
    """A tick-log listener that prints leaf results as they happen."""

    def __init__(self, built: BuiltTree, stream: IO[str] | None = None) -> None:
        self.stream = (
            stream or sys.stdout
        )  # looked up now, not at import: the stream may have been swapped since
        self.leaves = {node.id: node.spec.path for node in built.nodes if not node.spec.children}

    def __call__(self, record: dict[str, Any]) -> None:
        kind = record["type"]
        if kind in ("tick", "halt"):
            for node, _, after, feedback in record["changes"]:
                if node in self.leaves and (
                    after in ("SUCCESS", "FAILURE") or kind == "halt" and after == "INVALID"
                ):
                    shown = "HALTED" if kind == "halt" else after
                    note = f"  ({feedback})" if feedback else ""
                    print(f"{record['t']:8.3f} s  {shown:<7}  {self.leaves[node]}{note}", file=self.stream)
        elif kind == "message":
            print(
                f"{record['t']:8.3f} s  {record['level'].upper():<7}  {record['source']}: {record['text']}",
                file=self.stream,
            )
        elif kind == "end":
            print(
                f"{record['t']:8.3f} s  run ended: {record['outcome']} after {record['n']} ticks",
                file=self.stream,
            )
