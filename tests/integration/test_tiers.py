"""The test tiers hold: every test collected under `tests/system/` carries the `system` marker, so the fast
loop (`pytest -m "not system"`) leaves out exactly the system tier."""

from __future__ import annotations

import os
import re
import subprocess
import sys
from pathlib import Path

REPO = Path(__file__).resolve().parents[2]


def _collected(*args: str) -> str:
    env = {
        **os.environ,
        "PYTHONPATH": os.pathsep.join(filter(None, [str(REPO), os.environ.get("PYTHONPATH")])),
    }
    command = [
        sys.executable,
        "-m",
        "pytest",
        "--collect-only",
        "-q",
        "-p",
        "no:cacheprovider",
        "-p",
        "no:xdist",
    ]
    done = subprocess.run([*command, *args], capture_output=True, text=True, cwd=REPO, env=env, timeout=300)
    return done.stdout + done.stderr


def test_every_system_test_carries_the_system_marker() -> None:
    printed = _collected("-m", "not system", "tests/system")
    deselected = re.search(r"(\d+) deselected", printed)
    assert deselected and int(deselected.group(1)) > 0, printed[-2000:]
    assert "::" not in printed, printed[-2000:]  # no test id: none left once `system` is deselected
