"""Start-up: `pegbt --help` loads no heavy library, and a simulator child that never starts is given up on."""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import pytest

from pegbt.errors import PegbtError
from pegbt.sim import process

REPO = Path(__file__).resolve().parents[1]
HEAVY = ("zenoh", "scipy", "torch", "open3d", "matplotlib", "rosbags", "py_trees")


def test_the_parser_loads_no_heavy_library():
    """Handlers import what they need; building every command's parser (what --help does) must not."""
    probe = ("import sys; from pegbt.cli import build_parser; build_parser(); "
             f"print(sorted({{m.split('.')[0] for m in sys.modules}} & set({HEAVY!r})))")
    done = subprocess.run([sys.executable, "-c", probe], capture_output=True, text=True, cwd=REPO, timeout=60,
                          env=dict(os.environ, PYTHONPATH=str(REPO)))
    assert done.returncode == 0, done.stderr
    assert done.stdout.strip() == "[]"


def test_a_simulator_that_prints_nothing_in_time_is_killed_with_a_clear_error(monkeypatch):
    monkeypatch.setattr(process, "STARTUP_TIMEOUT", 0.01)  # far less than the child needs to import anything
    with pytest.raises(PegbtError, match=r"pegbt sim did not start: nothing within 0\.01 s"):
        process.SimProcess(["--no-world"])
