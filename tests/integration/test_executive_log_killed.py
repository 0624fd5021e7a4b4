"""The tick log of a run killed outright (no halt or end written): `log why` names the leaves still running."""

from __future__ import annotations

import os
import subprocess
import sys
import time
from pathlib import Path

from pegbt.executive.analysis import why
from pegbt.executive.logfile import read_tick_log

REPO = Path(__file__).resolve().parents[2]


def test_why_names_the_leaves_still_running_in_the_log_of_a_killed_run(tmp_path):
    """SIGKILL leaves no halt or end record: the leaves last logged RUNNING are the ones the run was in."""
    tree = tmp_path / "long.yaml"
    tree.write_text(
        "tree: {sequence: {name: task, children: [{log: {message: start}}, {wait: {name: long, seconds: 600}}]}}\n"
    )
    path = tmp_path / "killed.jsonl"
    env = {**os.environ, "PYTHONPATH": str(REPO)}
    command = [sys.executable, "-m", "pegbt", "run", str(tree), "--quiet", "--log", str(path)]
    process = subprocess.Popen(command, env=env, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    try:
        deadline = time.monotonic() + 60
        while '"RUNNING"' not in (path.read_text() if path.exists() else ""):
            assert process.poll() is None and time.monotonic() < deadline
            time.sleep(0.05)
    finally:
        process.kill()
        process.wait()
    log = read_tick_log(path)
    assert log.end is None and not any(change.halted for change in log.transitions)
    lines = why(log).splitlines()
    assert lines[1:3] == [
        "running when the run stopped:",
        "  /task/long  (waiting 600 s)  never halted: the log ends",
    ]
