"""The runner in real time: a tick that overruns its period never asks the clock for a negative wait, and
work a leaf offloads runs while the tree keeps ticking (in lockstep, the clock waits for it instead)."""

from __future__ import annotations

import json
import sys
import threading
import time

from executive_helpers import write_tree
from py_trees.common import Status

from pegbt.clock import ManualClock, WallClock
from pegbt.errors import PegbtError
from pegbt.executive.context import RunContext
from pegbt.executive.leaf import Leaf
from pegbt.executive.loader import load_tree
from pegbt.executive.params import Param
from pegbt.executive.registry import REGISTRY, behaviour
from pegbt.executive.runner import SWITCH_INTERVAL, run
from pegbt.executive.ticklog import TickLogWriter

if REGISTRY.get("test_slow_tick") is None:

    @behaviour(
        "test_slow_tick",
        "sleeps `seconds` in each of its first `ticks` ticks (work done in the tick), then succeeds",
        params=(Param("seconds", float, "s per tick"), Param("ticks", int, "slow ticks")),
    )
    class SlowTick(Leaf):
        def initialise(self) -> None:
            self.count = 0

        def update(self) -> Status:
            self.count += 1
            if self.count > self.params["ticks"]:
                return Status.SUCCESS
            time.sleep(self.params["seconds"])
            return Status.RUNNING

    @behaviour(
        "test_heavy",
        "computes off the tick: a job that waits until `/release` is set (or 10 s); writes `/answer`",
        writes=("/answer",),
    )
    class HeavyLeaf(Leaf):
        release = threading.Event()

        def initialise(self) -> None:
            self.job = None

        def update(self) -> Status:
            if self.job is None:
                self.job = self.offload(self.compute, 41)
            if not self.job.done:
                return Status.RUNNING
            self.write("/answer", self.job.result())
            return Status.SUCCESS

        @staticmethod
        def compute(value: int) -> int:
            HeavyLeaf.release.wait(10.0)
            return value + 1

    @behaviour(
        "test_switch_interval", "writes the interpreter's switch interval to `/switch`", writes=("/switch",)
    )
    class SwitchInterval(Leaf):
        def update(self) -> Status:
            self.write("/switch", sys.getswitchinterval())
            return Status.SUCCESS

    @behaviour("test_ticks", "counts its ticks into `/ticks`; runs until halted", writes=("/ticks",))
    class TickCounter(Leaf):
        def initialise(self) -> None:
            self.count = 0

        def update(self) -> Status:
            self.count += 1
            self.write("/ticks", self.count)
            if self.count == 5:  # the heavy leaf's job has seen the tree tick on: let it end
                HeavyLeaf.release.set()
            return Status.RUNNING

    @behaviour(
        "test_ends_between_ticks",
        "RUNNING until `seconds` after its first tick, a motion's end that only a poll sees at once",
        params=(Param("seconds", float, "s until it ends"),),
    )
    class EndsBetweenTicks(Leaf):
        def initialise(self) -> None:
            self.end = time.monotonic() + self.params["seconds"]
            self.wake_when = self.over

        def over(self) -> bool:
            return time.monotonic() >= self.end

        def update(self) -> Status:
            return Status.SUCCESS if self.over() else Status.RUNNING

    @behaviour(
        "test_wakes_at",
        "RUNNING until `seconds` after its first tick, with that end as its `wake_at`",
        params=(Param("seconds", float, "s until it ends"),),
    )
    class WakesAt(Leaf):
        def initialise(self) -> None:
            self.wake_at = self.context.clock.now() + self.params["seconds"]

        def update(self) -> Status:
            return Status.SUCCESS if self.context.clock.now() >= self.wake_at else Status.RUNNING


class StrictWallClock(WallClock):
    """Wall time that refuses a negative wait, as the simulator's clock does, and records every wait."""

    def __init__(self) -> None:
        self.waits: list[float] = []

    def wait(self, seconds: float) -> None:
        if seconds < 0:
            raise PegbtError(f"wait needs a finite duration >= 0, got {seconds}", field="seconds")
        self.waits.append(seconds)
        super().wait(seconds)


def _run(tmp_path, text: str, clock, period: float = 0.02):
    built = load_tree(write_tree(tmp_path, text)).build(RunContext(clock=clock))
    log_path = tmp_path / "run.jsonl"
    writer = TickLogWriter(log_path, built, clock_kind=type(clock).__name__)
    result = run(built, period=period, timeout=30.0, log=writer)
    return built, result, [json.loads(line) for line in log_path.read_text().splitlines()]


def test_a_tick_that_overruns_its_period_is_recorded_and_never_waits_negatively(tmp_path):
    clock = StrictWallClock()
    # a period long beside a loaded machine's scheduling delays, so that only the slow ticks overrun it
    text = "tree: {test_slow_tick: {name: slow, seconds: 0.3, ticks: 3}}"
    _, result, log = _run(tmp_path, text, clock, period=0.2)
    assert result.outcome == "success"
    assert result.overruns == 3 and result.late_max_s >= 0.1
    assert all(wait >= 0 for wait in clock.waits)
    late = [record for record in log if record["type"] == "tick" and "late_s" in record]
    assert [record["n"] for record in late] == [1, 2, 3]
    assert log[-1]["type"] == "end" and log[-1]["overruns"] == 3


def test_a_heavy_leaf_keeps_the_tree_ticking_in_real_time(tmp_path):
    HeavyLeaf.release.clear()
    text = """
    tree:
      parallel:
        policy: one
        children:
          - test_heavy: {name: heavy}
          - test_ticks: {name: ticker}
    """
    _, result, log = _run(tmp_path, text, WallClock())
    assert result.outcome == "success"
    ticks_while_computing = [record["bb"]["/ticks"] for record in log if "/ticks" in record.get("bb", {})]
    assert ticks_while_computing[:5] == [1, 2, 3, 4, 5]  # the tree ticked on while the job waited
    answered = next(record for record in log if "/answer" in record.get("bb", {}))
    assert answered["bb"]["/answer"] == 42 and answered["n"] > 5
    assert result.work.jobs == 1 and result.work.waited_s > 0


def test_in_lockstep_the_work_is_done_in_the_tick_that_asks_and_time_does_not_pass(tmp_path):
    HeavyLeaf.release.clear()
    threading.Timer(0.3, HeavyLeaf.release.set).start()  # the job takes 0.3 s of wall time
    _, result, log = _run(tmp_path, "tree: {test_heavy: {name: heavy}}", ManualClock())
    assert result.outcome == "success"
    assert result.duration == 0.0 and result.overruns == 0  # computing costs no time that stands still
    assert [record["n"] for record in log if record["type"] == "tick"] == [1]
    # the job computed until released (0.3 s after the test began, less the time the tree took to load)
    assert result.work.jobs == 1 and 0.0 < result.work.compute_s <= result.work.waited_s


def test_a_job_that_ends_wakes_the_tree_at_once_instead_of_a_period_later(tmp_path):
    HeavyLeaf.release.clear()
    threading.Timer(0.2, HeavyLeaf.release.set).start()  # the job ends 0.2 s in
    _, result, log = _run(tmp_path, "tree: {test_heavy: {name: heavy}}", WallClock(), period=5.0)
    assert result.outcome == "success"
    ticks = [record for record in log if record["type"] == "tick"]
    assert [record["n"] for record in ticks] == [1, 2]  # asked, then picked up: no tick in between
    assert ticks[1]["t"] < 2.5  # half the period: the job's end woke the runner, not the period
    assert result.work.by_kind == {"HeavyLeaf.compute": [1, result.work.compute_s, result.work.waited_s]}


def test_in_real_time_a_busy_worker_yields_the_gil_to_the_tick_within_the_lowered_switch_interval(tmp_path):
    """At the default 5 ms a worker in Python code kept the ticking thread waiting for the GIL each time it
    had let it go (sending, waiting), and ticks that sent a trajectory while a job computed overran."""
    before = sys.getswitchinterval()
    _, result, log = _run(tmp_path, "tree: {test_switch_interval: {name: switch}}", WallClock())
    assert result.outcome == "success"
    (during,) = [record["bb"]["/switch"] for record in log if "/switch" in record.get("bb", {})]
    assert during <= SWITCH_INTERVAL < before
    assert sys.getswitchinterval() == before  # restored once the run ends

    _, result, log = _run(tmp_path, "tree: {test_switch_interval: {name: switch}}", ManualClock())
    (during,) = [record["bb"]["/switch"] for record in log if "/switch" in record.get("bb", {})]
    assert during == before  # lockstep: nothing computes beside the tick


def test_in_real_time_a_leaf_that_can_go_on_between_ticks_is_ticked_at_once_not_a_period_later(tmp_path):
    """A motion reported done between two ticks was seen a period later: 20 ms for each motion of a transfer
    that lockstep, stopping its clock at the motion's end, never spent."""
    _, result, log = _run(
        tmp_path, "tree: {test_ends_between_ticks: {name: motion, seconds: 0.3}}", WallClock(), 2.0
    )
    assert result.outcome == "success"
    ticks = [record for record in log if record["type"] == "tick"]
    assert [record["n"] for record in ticks] == [1, 2]
    assert 0.3 <= ticks[1]["t"] < 1.0  # its end, polled; not the period's 2 s


def test_in_real_time_a_wake_hint_is_kept_as_it_is_in_lockstep_rounded_up_to_whole_periods(tmp_path):
    text = "tree: {test_wakes_at: {name: motion, seconds: 0.5}}"
    _, result, log = _run(tmp_path, text, WallClock(), 0.4)
    ticks = [record for record in log if record["type"] == "tick"]
    assert result.outcome == "success" and [record["n"] for record in ticks] == [1, 2]
    assert 0.5 <= ticks[1]["t"] < 0.7  # at the hint, not at the second period's 0.8 s

    _, result, log = _run(tmp_path, text, ManualClock(), 0.4)
    ticks = [record for record in log if record["type"] == "tick"]
    assert result.outcome == "success" and [record["t"] for record in ticks] == [0.0, 0.8]
