"""The runner: tick a built tree at a fixed period of the executive's clock until it finishes.

It stops on success, failure, a timeout (halting the tree) or Ctrl-C (halting the tree: every running
behaviour gets `terminate(INVALID)`, so a behaviour that started a motion stops it). With a tick log,
each of these ends up in the log; an exception escaping a behaviour is logged as a crash and re-raised.

Waking up: a running node may say when it next needs a tick by setting `wake_at` (a time on the run's
clock; `math.inf`: only when something else changes, e.g. a blackboard wait). When every running leaf
has such a hint and the tick wrote nothing to the blackboard, the runner lets the clock run to the
earliest hint (in whole periods) instead of ticking every period: a trajectory of 1.5 s is one wait,
not 75. Running nodes that are not leaves (a timeout) constrain the wait with their own hints. Without
hints the runner ticks every period. In real time the hint is kept as it is, not rounded up: a robot's
motion ends when it ends, not on the tick grid.

Ticking as soon as a leaf can go on (real time): a leaf may also set `wake_when`, a test that is true once
a tick would find it changed (its motions reported done). While the runner waits it checks these every
`POLL` s and ticks at once when one is true. A motion reported done between two ticks was otherwise seen
up to a period later, each motion of a transfer: in lockstep the clock stops exactly at a motion's end
(its duration is a whole number of the simulator's steps), so each costs real time a period that lockstep
never spends.

Overruns: a tick that takes longer than the period on the run's clock (real time: perception or planning
in the tick, a loaded machine) is recorded (the tick log's `late_s`, `RunResult.overruns`) and the next
tick starts at once; time never has to run backwards. Work a leaf offloads (`pegbt.executive.work`)
runs while the tree keeps ticking; with a clock whose time stands still while the tree computes
(lockstep), it runs in the tick that asks for it instead, so runs stay deterministic and unchanged.

In real time the interpreter's switch interval is lowered while the tree runs (`SWITCH_INTERVAL`): a
worker busy in Python code (a grasp choice sweeping clearances, IK) holds the GIL for up to the switch
interval each time the ticking thread (or the transport's streamer) wants it back after sending or
waiting, and at the default 5 ms a tick that sends a trajectory while a job computes overran its 20 ms.
"""

from __future__ import annotations

import math
import sys
import time
import traceback
from collections.abc import Callable
from dataclasses import dataclass, field

import py_trees
from py_trees.common import Status

from pegbt.clock import is_realtime
from pegbt.executive.build import BuiltTree
from pegbt.executive.ticklog import TickLogWriter
from pegbt.executive.work import WorkStats

SWITCH_INTERVAL = 0.0005  # s: the longest a thread keeps the GIL from one that waits for it, in real time
POLL = 0.002  # s between checks of the running leaves' `wake_when` while the runner waits, in real time


@dataclass(frozen=True)
class RunResult:
    """How a run ended: `outcome` is success, failure, timeout or interrupted; `overruns` counts ticks that
    took longer than the period (the longest by `late_max_s`); `work` what leaves computed off the tick."""

    outcome: str
    ticks: int
    duration: float
    overruns: int = 0
    late_max_s: float = 0.0
    work: WorkStats = field(default_factory=WorkStats)


def set_initial_blackboard(built: BuiltTree) -> None:
    """Write the tree file's `blackboard:` values before the first tick."""
    if built.initial_blackboard:
        writer = py_trees.blackboard.Client(name="initial blackboard")
        for key, value in built.initial_blackboard.items():
            writer.register_key(key=key, access=py_trees.common.Access.WRITE)
            writer.set(key, value, overwrite=True)


def run(
    built: BuiltTree, *, period: float, timeout: float | None = None, log: TickLogWriter | None = None
) -> RunResult:
    """Set up and tick `built` every `period` seconds of its context's clock; see the module docstring for how it ends."""
    clock = built.context.clock
    work = built.context.work
    built.context.period = period
    work.inline = not is_realtime(clock)
    switch_interval = sys.getswitchinterval()
    if not work.inline:
        sys.setswitchinterval(min(switch_interval, SWITCH_INTERVAL))
    root = built.root
    start = clock.now()
    ticks = overruns = 0
    late_max = 0.0
    outcome = "interrupted"
    try:
        set_initial_blackboard(built)
        root.setup_with_descendants()  # behaviours acquire their resources here; a failure is logged as a crash
        while True:
            ticks += 1
            tick_start = clock.now()
            wall = time.perf_counter()
            before = dict(py_trees.blackboard.Blackboard.storage)
            if log is None:
                root.tick_once()
            else:
                log.tick_logged()
            late = clock.now() - (tick_start + period)
            if late > 0:
                overruns += 1
                late_max = max(late_max, late)
            if log is not None:
                log.tick(ticks, tick_start - start, time.perf_counter() - wall, max(late, 0.0))
            if root.status in (Status.SUCCESS, Status.FAILURE):
                outcome = root.status.value.lower()
                break
            if timeout is not None and clock.now() - start >= timeout:
                outcome = "timeout"
                _halt(root, log, ticks, clock.now() - start, "timeout")
                break
            if _changed(before):
                wake = tick_start + period
            else:
                wake = next_wake(built, tick_start, period, whole_periods=work.inline)
            if timeout is not None:
                wake = min(wake, start + timeout)
            seconds = max(0.0, max(tick_start + period, wake) - clock.now())
            work.wait(clock, seconds, until=None if work.inline else wake_when(built), poll=POLL)
    except KeyboardInterrupt:
        _halt(root, log, ticks, clock.now() - start, "interrupt")
    except Exception as error:
        outcome = "crash"
        if log is not None:
            log.crash(ticks, clock.now() - start, error, traceback.format_exc())
        _halt(root, log, ticks, clock.now() - start, "crash")
        raise
    finally:
        sys.setswitchinterval(switch_interval)
        work.close()
        if log is not None:
            log.end(ticks, clock.now() - start, outcome, overruns=overruns, work=work.stats.as_dict())
            log.close()
    return RunResult(outcome, ticks, clock.now() - start, overruns, late_max, work.stats)


def _changed(before: dict) -> bool:
    """Whether the tick wrote the blackboard (a new value or key): a waiting node may now go on."""
    after = py_trees.blackboard.Blackboard.storage
    return len(after) != len(before) or any(
        before.get(key, before) is not value for key, value in after.items()
    )


def next_wake(built: BuiltTree, now: float, period: float, *, whole_periods: bool = True) -> float:
    """When the tree next needs a tick: the earliest `wake_at` of its running nodes (rounded up to whole
    periods after `now` with `whole_periods`, never sooner than a period), if every running leaf gave one;
    else one period after `now`."""
    hints = []
    for node in built.nodes:
        behaviour = node.behaviour
        if behaviour.status is not Status.RUNNING:
            continue
        hint = getattr(behaviour, "wake_at", None)
        if hint is None:
            if not node.spec.children:
                return now + period
            continue
        hints.append(hint)
    earliest = min(hints, default=math.inf)
    if not math.isfinite(earliest) or earliest <= now + period:
        return now + period
    if not whole_periods:
        return earliest
    return now + period * math.ceil((earliest - now) / period - 1e-9)


def wake_when(built: BuiltTree) -> Callable[[], bool] | None:
    """A test that is true once any running leaf's `wake_when` is (None if no running leaf gave one)."""
    tests = [
        test
        for node in built.nodes
        if node.behaviour.status is Status.RUNNING
        and (test := getattr(node.behaviour, "wake_when", None)) is not None
    ]
    if not tests:
        return None
    return lambda: any(test() for test in tests)


def _halt(
    root: py_trees.behaviour.Behaviour, log: TickLogWriter | None, ticks: int, t: float, reason: str
) -> None:
    root.stop(Status.INVALID)
    if log is not None:
        log.halt(ticks, t, reason)
