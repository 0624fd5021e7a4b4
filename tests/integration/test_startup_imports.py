"""What a user runs after each edit of a tree answers in a blink: `pegbt tree check|show|schema` and
`pegbt log why` load none of the libraries only running leaves need (their import alone takes seconds);
checking a tree, its schema and `log why` load not even what building one needs (py_trees, NumPy)."""

from __future__ import annotations

from pathlib import Path

import pytest
from startup_helpers import modules_loaded_after

from pegbt.cli import main

REPO = Path(__file__).resolve().parents[2]
HEAVY = ("torch", "open3d", "scipy.signal", "matplotlib", "dask", "distributed", "aiohttp")
# what the leaves and the tree they are built into run with: the declarations alone check a tree
NOT_TO_CHECK = (*HEAVY, "py_trees", "pydot", "numpy", "scipy", "rich", "zenoh", "rosbags")


def _heavy_modules_loaded_by(argv: list[str], cwd: Path, heavy: tuple[str, ...] = HEAVY) -> list[str]:
    """The modules of `heavy` a fresh interpreter holds after `pegbt ARGV` ran there and succeeded."""
    run = f"from pegbt.cli import main\nif main({argv!r}) != 0:\n    raise SystemExit('pegbt failed')"
    return modules_loaded_after(run, heavy, cwd)


def test_tree_show_loads_no_heavy_library():
    assert _heavy_modules_loaded_by(["tree", "show", "trees/handover.yaml"], REPO) == []


@pytest.mark.parametrize(
    "argv",
    [
        ["tree", "check", "trees/handover.yaml", "trees/unilateral.yaml", "trees/bilateral.yaml"],
        ["tree", "check", "trees/calibrate_collect.yaml", "trees/example.yaml"],
        ["tree", "schema"],
    ],
)
def test_checking_a_tree_loads_nothing_the_leaves_run_with(argv):
    assert _heavy_modules_loaded_by(argv, REPO, NOT_TO_CHECK) == []


def test_log_why_loads_nothing_the_leaves_run_with(tmp_path):
    log = tmp_path / "example.jsonl"
    example = str(REPO / "trees" / "example.yaml")
    assert main(["run", example, "--clock", "manual", "--period", "0.01", "--log", str(log), "--quiet"]) == 0
    assert _heavy_modules_loaded_by(["log", "why", str(log)], tmp_path, NOT_TO_CHECK) == []
