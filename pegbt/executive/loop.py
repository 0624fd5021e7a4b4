"""`ForEach`: the `for_each` node, a sequence over one instance of a subtree per item of a list.

Its children (built from a named list of the tree files, one subtree instance per item) run in order,
each to completion. `keep_going` is what a `force_success` around each item did: an item that fails is
recorded as failed, and the loop goes on with the next (BT.CPP's `LoopNode` and Nav2's waypoint
following do the same with their items).
"""

from __future__ import annotations

from collections.abc import Iterator

import py_trees
from py_trees.behaviour import Behaviour
from py_trees.common import Status


class ForEach(py_trees.composites.Sequence):
    """A sequence with memory that, with `keep_going`, moves on past a failed child and then succeeds."""

    def __init__(self, name: str, children: list[Behaviour], keep_going: bool) -> None:
        super().__init__(name, memory=True, children=children)
        self.keep_going = keep_going

    def tick(self) -> Iterator[Behaviour]:
        if self.status != Status.RUNNING:
            for child in self.children:
                if child.status != Status.INVALID:
                    child.stop(Status.INVALID)
            self.current_child = self.children[0] if self.children else None
            self.initialise()
        index = self.children.index(self.current_child) if self.current_child is not None else 0
        for child in self.children[index:]:
            self.current_child = child
            yield from child.tick()
            if child.status == Status.RUNNING or (child.status == Status.FAILURE and not self.keep_going):
                if child.status == Status.RUNNING:
                    self.status = Status.RUNNING
                else:
                    self.stop(Status.FAILURE)
                yield self
                return
        self.stop(Status.SUCCESS)
        yield self
