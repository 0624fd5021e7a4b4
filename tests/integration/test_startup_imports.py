"""What a user runs after each edit of a tree answers in a blink: `pegbt tree check|show|schema` and
`pegbt log why` load none of the libraries only running leaves need (their import alone takes seconds)."""

from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

import pytest

from pegbt.cli import main

REPO = Path(__file__).resolve().parents[2]
HEAVY = ("torch", "open3d", "scipy.signal", "matplotlib", "dask", "distributed", "aiohttp")


def _heavy_modules_loaded_by(argv: list[str], cwd: Path) -> list[str]:
    """Runs `pegbt ARGV` in a fresh interpreter; the heavy modules in its `sys.modules` afterwards."""
    probe = (
        "import json, sys\n"
        "from pegbt.cli import main\n"
        f"status = main({argv!r})\n"
        f"print(json.dumps([status, sorted(m for m in {HEAVY!r} if m in sys.modules)]))\n"
    )
    done = subprocess.run(
        [sys.executable, "-c", probe],
        capture_output=True,
        text=True,
        cwd=cwd,
        timeout=120,
        env=dict(os.environ, PYTHONPATH=str(REPO)),
    )
    assert done.returncode == 0, done.stderr
    status, loaded = json.loads(done.stdout.strip().splitlines()[-1])
    assert status == 0, done.stdout + done.stderr
    return loaded


@pytest.mark.parametrize(
    "argv",
    [
        ["tree", "check", "trees/handover.yaml", "trees/unilateral.yaml", "trees/bilateral.yaml"],
        ["tree", "show", "trees/handover.yaml"],
        ["tree", "schema"],
    ],
)
def test_the_tree_commands_load_no_heavy_library(argv):
    assert _heavy_modules_loaded_by(argv, REPO) == []


def test_log_why_loads_no_heavy_library(tmp_path):
    log = tmp_path / "example.jsonl"
    example = str(REPO / "trees" / "example.yaml")
    assert main(["run", example, "--clock", "manual", "--period", "0.01", "--log", str(log), "--quiet"]) == 0
    assert _heavy_modules_loaded_by(["log", "why", str(log)], tmp_path) == []
