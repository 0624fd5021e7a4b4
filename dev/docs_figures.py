"""Make the README's pictures: the monitor's live and replay pages (headless Debian chromium via Playwright),
one run's timeline (`pegbt log plot`) and `pegbt eval`'s figures copied from an --out folder.

    PYTHONPATH=. .venv/bin/python dev/docs_figures.py EVAL_OUT_DIR   # writes docs/*.png
"""

from __future__ import annotations

import os
import shutil
import sys
import tempfile
import threading
import time
from pathlib import Path

from playwright.sync_api import sync_playwright

from pegbt.bench.chromium import headless_chromium
from pegbt.cli import main
from pegbt.executive.session import run_tree_file
from pegbt.monitor.history import History
from pegbt.monitor.live import LiveMonitor
from pegbt.monitor.replay import replay_messages
from pegbt.monitor.server import MonitorServer, start_ephemeral
from pegbt.sim.process import free_port

REPO = Path(__file__).resolve().parents[1]
DOCS = REPO / "docs"
UNILATERAL = Path("trees/unilateral.yaml")  # relative: the pages show the path as a user types it
HANDOVER = Path("trees/handover.yaml")


def monitored_run(
    log: Path, server: MonitorServer, condition: str, seed: int, blackboard: dict, tree: Path = UNILATERAL
) -> None:
    monitor = LiveMonitor(server, log)
    try:
        run_tree_file(
            tree,
            log,
            options={"endpoint": "auto", "condition": condition, "seed": seed},
            blackboard=blackboard,
            watch=monitor.watch,
        )
    finally:
        monitor.stop()


def live_page(browser, work: Path) -> None:
    server = MonitorServer(free_port()).start()
    run = threading.Thread(
        target=monitored_run, args=(work / "live.jsonl", server, "optimized", 1000, {}), daemon=True
    )
    run.start()
    page = browser.new_page(viewport={"width": 1500, "height": 900})
    page.goto(server.url)
    page.wait_for_function("Number(document.getElementById('tick').textContent) > 120", timeout=120_000)
    page.click("#running li")  # the running leaf, shown in the tree with its source
    time.sleep(0.5)
    page.screenshot(path=DOCS / "monitor-live.png")
    page.close()
    run.join()
    server.stop()


def replay_page(browser, log: Path, out: str, button: str) -> None:
    """A screenshot of the replay of `log` after clicking `button` (first cause, fold subtrees)."""
    server = start_ephemeral(replay_messages(log), history=History.whole())
    page = browser.new_page(viewport={"width": 1500, "height": 900})
    page.goto(server.url)
    page.wait_for_function("window.pegbtMonitor.loadedAt !== null")
    page.click(button)
    time.sleep(0.5)
    page.screenshot(path=DOCS / out)
    page.close()
    server.stop()


def main_(eval_out: Path) -> None:
    os.chdir(REPO)
    DOCS.mkdir(exist_ok=True)
    with tempfile.TemporaryDirectory() as folder, sync_playwright() as playwright:
        work = Path(folder)
        browser = headless_chromium(playwright)
        live_page(browser, work)
        failed = work / "failed.jsonl"  # uncalibrated, and a block that cannot be moved fails the trial
        server = MonitorServer(free_port()).start()
        monitored_run(failed, server, "uncalibrated", 1001, {"/policy/skip_failed_blocks": False})
        server.stop()
        replay_page(browser, failed, "monitor-replay.png", "#first-cause")
        handover = work / "handover.jsonl"  # 2,300 nodes; uncalibrated, so the tree gives up on blocks
        server = MonitorServer(free_port()).start()
        monitored_run(handover, server, "uncalibrated", 1000, {}, HANDOVER)
        server.stop()
        replay_page(browser, handover, "monitor-handover-folded.png", "#fold")
        browser.close()
        main(["log", "plot", str(failed), "--out", str(DOCS / "log-plot.png")])
    for name in ("transfer_times.png", "trial_figures.png"):
        shutil.copy(eval_out / name, DOCS / name)


if __name__ == "__main__":
    main_(Path(sys.argv[1]))
