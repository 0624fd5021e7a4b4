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


def test_modules_with_a_slow_test_run_first_then_the_system_tier_each_module_in_one_piece(request) -> None:
    """Checked on this run's own collection, whatever part of the suite it is."""
    ranks, modules = [], []
    for item in request.session.items:
        if not modules or modules[-1] != item.path:
            modules.append(item.path)
            ranks.append(2)
        own = 0 if item.get_closest_marker("slow") else 1 if item.get_closest_marker("system") else 2
        ranks[-1] = min(ranks[-1], own)
    assert len(set(modules)) == len(modules), "a module split in two"
    assert ranks == sorted(ranks), list(zip(ranks, modules, strict=True))
