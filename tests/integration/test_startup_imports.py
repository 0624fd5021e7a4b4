"""What a user runs after each edit of a tree answers in a blink: `pegbt tree check|show|schema` and
`pegbt log why` load none of the libraries only running leaves need (their import alone takes seconds)."""

from __future__ import annotations

from pathlib import Path

import pytest
from startup_helpers import modules_loaded_after

from pegbt.cli import main

REPO = Path(__file__).resolve().parents[2]
HEAVY = ("torch", "open3d", "scipy.signal", "matplotlib", "dask", "distributed", "aiohttp")


def _heavy_modules_loaded_by(argv: list[str], cwd: Path) -> list[str]:
    """The heavy modules a fresh interpreter holds after `pegbt ARGV` ran there and succeeded."""
    run = f"from pegbt.cli import main\nif main({argv!r}) != 0:\n    raise SystemExit('pegbt failed')"
    return modules_loaded_after(run, HEAVY, cwd)


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
