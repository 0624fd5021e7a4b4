"""`pegbt bench executive`: cost of a tick with and without the tick log, and of loading a tree file.

- `tick_us_plain`: median µs per tick of a 62-node tree ticked by py_trees alone. Its leaves run for
  a few ticks each (as motions do, though real ones run for hundreds), so most ticks change something.
- `tick_us_logged`: the same tree ticked through the tick-log writer (status and blackboard diffs,
  JSON lines written unbuffered to a file), in blocks interleaved with the plain ones so that
  machine load hits both. `logged_ratio` is the median of the per-round ratios (adjacent blocks see
  the same load), goal at most 1.3.
- `busy_*`: the same for a tree whose leaves change on almost every tick (a worst case).
- `load_ms`: median time to load and validate the largest tree file in `trees/` (most nodes, includes read).
"""

from __future__ import annotations

import statistics
import tempfile
import time
from pathlib import Path

from pegbt.bench import Figures
from pegbt.clock import ManualClock
from pegbt.executive.context import RunContext
from pegbt.executive.loader import load_tree
from pegbt.executive.runner import set_initial_blackboard
from pegbt.executive.ticklog import TickLogWriter

TREES = Path(__file__).resolve().parents[2] / "trees"
ROUNDS = 41
BLOCK = 100

# Four instances of an arm subtree in parallel, forever; {R} stands for a run of `running` outcomes.
BENCH_TREE = """
blackboard: {go: true}
subtrees:
  arm:
    args: {arm: str}
    tree:
      sequence:
        name: cycle ${arm}
        children:
          - set_blackboard: {name: sense, key: pose, value: "pose ${arm}"}
          - guard:
              key: /go
              child:
                recover:
                  retries: 1
                  main: {scripted: {name: grasp, outcomes: [{R}, failure, {R}, success], then: cycle}}
                  recovery: {scripted: {name: regrasp, outcomes: [{R}, success], then: cycle}}
          - retry:
              attempts: 3
              child: {scripted: {name: lift, outcomes: [{R}, success], then: cycle}}
          - timeout:
              seconds: 100
              child: {scripted: {name: carry, outcomes: [{R}, {R}, success], then: cycle}}
          - selector:
              children:
                - check_blackboard: {name: placed?, key: pose, value: none}
                - scripted: {name: place, outcomes: [{R}, success], then: cycle}
          - set_blackboard: {name: count, key: done, value: $pose}
tree:
  repeat:
    times: -1
    child:
      parallel:
        name: arms
        policy: all
        children:
          - subtree: {use: arm, args: {arm: A}}
          - subtree: {use: arm, args: {arm: B}}
          - subtree: {use: arm, args: {arm: C}}
          - subtree: {use: arm, args: {arm: D}}
"""


def _largest_tree() -> Path:
    """The tree file with the most nodes once its subtrees are expanded."""
    return max(sorted(TREES.rglob("*.yaml")), key=lambda path: load_tree(path).node_count())


def _tick_costs(directory: Path, running_ticks: int) -> tuple[int, float, float, float, float]:
    """(nodes, plain µs per tick, logged µs per tick, median logged/plain ratio, log records per tick)."""
    source = directory / f"bench-{running_ticks}.yaml"
    source.write_text(BENCH_TREE.replace("{R}", ", ".join(["running"] * running_ticks)), encoding="utf-8")
    built = load_tree(source).build(RunContext(clock=ManualClock()))
    set_initial_blackboard(built)
    root = built.root
    log_path = directory / f"bench-{running_ticks}.jsonl"
    writer = TickLogWriter(log_path, built, clock_kind="manual")
    plain, logged, tick = [], [], 0
    for _ in range(ROUNDS):
        start = time.perf_counter()
        for _ in range(BLOCK):
            root.tick_once()
        plain.append((time.perf_counter() - start) / BLOCK)
        start = time.perf_counter()
        for _ in range(BLOCK):
            tick += 1
            wall = time.perf_counter()
            writer.tick_logged()
            writer.tick(tick, tick * 0.01, time.perf_counter() - wall)
        logged.append((time.perf_counter() - start) / BLOCK)
    writer.close()
    with log_path.open() as log:
        records = sum(1 for _ in log) - 1
    ratio = statistics.median(after / before for before, after in zip(plain, logged))
    return (
        len(built.nodes),
        statistics.median(plain) * 1e6,
        statistics.median(logged) * 1e6,
        ratio,
        records / tick,
    )


def run() -> Figures:
    with tempfile.TemporaryDirectory() as directory:
        nodes, plain, logged, ratio, records = _tick_costs(Path(directory), running_ticks=5)
        _, busy_plain, busy_logged, busy_ratio, busy_records = _tick_costs(Path(directory), running_ticks=1)
    largest = _largest_tree()
    loads = []
    for _ in range(20):
        start = time.perf_counter()
        load_tree(largest)
        loads.append(time.perf_counter() - start)
    return {
        "nodes": nodes,
        "tick_us_plain": round(plain, 1),
        "tick_us_logged": round(logged, 1),
        "logged_ratio": round(ratio, 3),
        "log_records_per_tick": round(records, 3),
        "busy_tick_us_plain": round(busy_plain, 1),
        "busy_tick_us_logged": round(busy_logged, 1),
        "busy_logged_ratio": round(busy_ratio, 3),
        "busy_log_records_per_tick": round(busy_records, 3),
        "load_ms": round(statistics.median(loads) * 1e3, 2),
        "load_file": str(largest.relative_to(TREES.parent)),
    }
