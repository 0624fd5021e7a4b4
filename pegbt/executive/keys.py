"""Blackboard key check: every key a node reads must be written by some node or set by `blackboard:`.

Keys are compared as absolute names, so a subtree instance reading `block_pose` needs a writer of
`/<its namespace>/block_pose`, not of some other instance's key.
"""

from __future__ import annotations

from pegbt.executive.problems import Problems, did_you_mean
from pegbt.executive.spec import NodeSpec


def check_keys(root: NodeSpec, initial: set[str], problems: Problems) -> None:
    """Record a problem for each key read but neither written by a node nor in `initial`."""
    written = set(initial)
    for node in root.walk():
        written.update(use.key for use in node.keys if use.access == "write")
    for node in root.walk():
        for use in node.keys:
            if use.access == "read" and use.key not in written:
                problems.add(
                    f"reads blackboard key {use.key!r}, which no node writes and `blackboard:` does not set"
                    f"{did_you_mean(use.key, written)}",
                    use.mark,
                    path=node.path,
                    field=use.field,
                )
