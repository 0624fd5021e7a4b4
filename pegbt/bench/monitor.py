"""`pegbt bench monitor`: how fast the monitor page shows a large tree, steps through it, and takes records.

- `load_ms_2001`: median ms from navigation to the replay page showing a 2,001-node tree (`wide_tree`: 50
  selectors of 38 failing blackboard checks and a wait, one after another) after its last tick, in
  headless Debian chromium, over `LOADS` page loads;
  `load_ms_example`: the same for `trees/example.yaml` (30 nodes), the baseline, loaded in turn with it.
- `step_ms_2001`: median ms per step of the big tree's replay, stepping through every tick and back.
- `publish_us`: median µs the run's thread spends handing one tick record to the server (`publish`).

Needs chromium and Playwright (`dev/setup test`).
"""

from __future__ import annotations

import statistics
import tempfile
import time
from pathlib import Path

from pegbt.bench import Figures
from pegbt.bench.chromium import headless_chromium
from pegbt.errors import PegbtError

TREES = Path(__file__).resolve().parents[2] / "trees"
LOADS = 5


def wide_tree(branches: int = 50, checks: int = 38) -> str:
    """A tree file of 1 + branches × (checks + 2) nodes run one branch after another: each a selector whose
    blackboard checks all fail, then a short wait that succeeds, so every branch changes over a few ticks."""
    lines = ["blackboard: {flag: -1}", "tree:", "  sequence:", "    name: big", "    children:"]
    for branch in range(branches):
        lines += ["      - selector:", f"          name: branch {branch}", "          children:"]
        lines += [
            f"            - check_blackboard: {{name: check {branch}.{check}, key: flag, value: {check}}}"
            for check in range(checks)
        ]
        lines.append(f"            - wait: {{name: wait {branch}, seconds: 0.04}}")
    return "\n".join(lines) + "\n"


def run() -> Figures:
    from pegbt.executive.runoptions import RunOptions
    from pegbt.executive.session import run_tree_file
    from pegbt.monitor.history import History
    from pegbt.monitor.replay import replay_messages
    from pegbt.monitor.server import start_ephemeral

    try:
        from playwright.sync_api import sync_playwright
    except ImportError:
        raise PegbtError("pegbt bench monitor needs playwright: run dev/setup test") from None
    with tempfile.TemporaryDirectory() as folder:
        big_tree = Path(folder) / "big.yaml"
        big_tree.write_text(wide_tree())
        logs = {}
        for name, tree in (("2001", big_tree), ("example", TREES / "example.yaml")):
            logs[name] = Path(folder) / f"{name}.jsonl"
            run_tree_file(RunOptions(tree, logs[name], clock="manual"))
        servers = {
            name: start_ephemeral(replay_messages(log), history=History.whole()) for name, log in logs.items()
        }
        loads: dict[str, list[float]] = {name: [] for name in logs}
        with sync_playwright() as playwright:
            browser = headless_chromium(playwright)
            for _ in range(LOADS):
                for name, server in servers.items():
                    page = browser.new_page(viewport={"width": 1400, "height": 900})
                    page.goto(server.url)
                    page.wait_for_function("window.pegbtMonitor.loadedAt !== null", timeout=60_000)
                    loads[name].append(page.evaluate("window.pegbtMonitor.loadedAt"))
                    page.close()
            page = browser.new_page(viewport={"width": 1400, "height": 900})
            page.goto(servers["2001"].url)
            page.wait_for_function("window.pegbtMonitor.loadedAt !== null", timeout=60_000)
            steps = page.evaluate(
                """() => { const m = window.pegbtMonitor, last = m.state.lastTick, times = [];
                  for (const tick of [...Array(last + 1).keys(), ...Array(last + 1).keys()].reverse()) {
                    const start = performance.now(); m.showTick(tick); times.push(performance.now() - start); }
                  return times; }"""
            )
            browser.close()
        for server in servers.values():
            server.stop()
        publish = _publish_us()
    return {
        "load_ms_2001": round(statistics.median(loads["2001"]), 1),
        "load_ms_example": round(statistics.median(loads["example"]), 1),
        "step_ms_2001": round(statistics.median(steps), 3),
        "steps": len(steps),
        "publish_us": round(publish, 2),
    }


def _publish_us() -> float:
    from pegbt.monitor.server import start_ephemeral

    record = {
        "type": "tick",
        "n": 1,
        "t": 0.02,
        "dt_us": 40.0,
        "changes": [[3, "INVALID", "RUNNING", "moving"]],
    }
    server = start_ephemeral()
    try:
        times = []
        for _ in range(2000):
            start = time.perf_counter()
            server.publish(record)
            times.append(time.perf_counter() - start)
    finally:
        server.stop()
    return statistics.median(times) * 1e6
