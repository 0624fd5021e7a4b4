"""Shared helpers for the executive tests: build trees from YAML text and tick them on a manual clock."""

from __future__ import annotations

import textwrap
from pathlib import Path

import py_trees
from py_trees.common import Status

from pegbt.clock import ManualClock
from pegbt.executive.build import BuiltTree
from pegbt.executive.context import RunContext
from pegbt.executive.leaf import Leaf
from pegbt.executive.loader import load_tree
from pegbt.executive.params import Param
from pegbt.executive.registry import REGISTRY, behaviour
from pegbt.executive.runner import set_initial_blackboard


def write_tree(directory: Path, text: str, name: str = "tree.yaml") -> Path:
    path = directory / name
    path.write_text(textwrap.dedent(text), encoding="utf-8")
    return path


def build_text(directory: Path, text: str, clock: ManualClock | None = None) -> BuiltTree:
    """Load, validate and build a tree from YAML text; initial blackboard values are set."""
    built = load_tree(write_tree(directory, text)).build(RunContext(clock=clock or ManualClock()))
    set_initial_blackboard(built)
    return built


def node(built: BuiltTree, name: str) -> py_trees.behaviour.Behaviour:
    matches = [entry.behaviour for entry in built.nodes if entry.spec.name == name]
    assert len(matches) == 1, f"{len(matches)} nodes named {name!r}"
    return matches[0]


def tick_statuses(
    built: BuiltTree, ticks: int, clock: ManualClock | None = None, step: float = 0.1
) -> list[Status]:
    """The root's status after each of `ticks` ticks (advancing `clock` by `step` between ticks)."""
    statuses = []
    for _ in range(ticks):
        built.root.tick_once()
        statuses.append(built.root.status)
        if clock is not None:
            clock.advance(step)
    return statuses


if REGISTRY.get("test_motion") is None:

    @behaviour(
        "test_motion",
        "test double of a motion: runs until halted or `ticks` ticks passed; records terminate calls",
        params=(Param("ticks", int, "ticks until success", default=1000),),
    )
    class TestMotion(Leaf):
        terminated: list[tuple[str, Status]] = []

        def initialise(self) -> None:
            self.count = 0

        def update(self) -> Status:
            self.count += 1
            return Status.SUCCESS if self.count >= self.params["ticks"] else Status.RUNNING

        def terminate(self, new_status: Status) -> None:
            if self.status == Status.RUNNING and new_status == Status.INVALID:
                TestMotion.terminated.append((self.name, new_status))

    @behaviour("test_crash", "raises RuntimeError when ticked")
    class TestCrash(Leaf):
        def update(self) -> Status:
            raise RuntimeError("behaviour bug")


def motion_class() -> type:
    return REGISTRY.get("test_motion").factory


class Counter:
    """A stand-in resource: counts uses, remembers being closed."""

    instances: list[Counter] = []

    def __init__(self, setup: object) -> None:
        self.clock = setup.clock
        self.options = setup.options
        self.uses = 0
        self.closed = False
        Counter.instances.append(self)

    def close(self) -> None:
        self.closed = True


if REGISTRY.get("test_counting") is None:

    @behaviour(
        "test_counting",
        "uses the `counter` resource once, writes `step` + 1 to `uses`, then succeeds",
        reads=("step",),
        writes=("uses",),
        resources=("counter",),
    )
    class TestCounting(Leaf):
        def setup(self, **kwargs: object) -> None:
            self.counter = self.context.resource("counter", Counter)

        def update(self) -> Status:
            self.counter.uses += 1
            self.write("uses", self.read("step") + self.counter.uses)
            return Status.SUCCESS


def with_shared_trees(folder: Path) -> Path:
    """`folder` holding a copy of the shipped `trees/shared/`, so a test tree written there may include
    `shared/NAME.yaml` (includes stay inside the tree's own folder)."""
    import shutil

    shutil.copytree(
        Path(__file__).resolve().parents[1] / "trees" / "shared", folder / "shared", dirs_exist_ok=True
    )
    return folder
