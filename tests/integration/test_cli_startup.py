"""Start-up and shut-down: `pegbt --help` loads no heavy library, a simulator child that never starts is given
up on, and one whose parent dies stops."""

from __future__ import annotations

import os
import subprocess
import sys
import time
from pathlib import Path

import pytest
from startup_helpers import modules_loaded_after

from pegbt.errors import PegbtError
from pegbt.sim import process

REPO = Path(__file__).resolve().parents[2]
HEAVY = ("zenoh", "scipy", "torch", "open3d", "matplotlib", "rosbags", "py_trees")


def test_the_parser_loads_no_heavy_library():
    """Handlers import what they need; building every command's parser (what --help does) must not."""
    assert modules_loaded_after("from pegbt.cli import build_parser; build_parser()", HEAVY) == []


def test_a_simulator_that_prints_nothing_in_time_is_killed_with_a_clear_error(monkeypatch):
    monkeypatch.setattr(process, "STAGE_TIMEOUT", 0.01)  # far less than the child needs to import anything
    with pytest.raises(PegbtError, match=r"pegbt sim did not start: nothing within 0\.01 s"):
        process.SimProcess(["--no-world"])


def test_a_simulator_stops_when_the_process_that_started_it_is_killed(tmp_path):
    """A killed parent (an eval run stopped with SIGKILL, a crashed test) leaves no simulator serving."""
    pid_file = tmp_path / "sim.pid"
    parent = subprocess.Popen(
        [
            sys.executable,
            "-c",
            (
                "import pathlib, sys, time\n"
                "from pegbt.sim.process import SimProcess\n"
                "sim = SimProcess(['--no-world'])\n"
                f"pathlib.Path({str(pid_file)!r}).write_text(str(sim.process.pid))\n"
                "time.sleep(60)\n"
            ),
        ],
        env={**os.environ, "PYTHONPATH": str(REPO)},
    )
    deadline = time.monotonic() + 60
    while not pid_file.exists() or not pid_file.read_text():
        assert parent.poll() is None and time.monotonic() < deadline, "the parent never started its simulator"
        time.sleep(0.1)
    sim_pid = int(pid_file.read_text())
    parent.kill()
    parent.wait()
    deadline = time.monotonic() + 20
    while Path(f"/proc/{sim_pid}").exists() and _state(sim_pid) != "Z":
        assert time.monotonic() < deadline, "the simulator kept serving after its parent was killed"
        time.sleep(0.1)


def _state(pid: int) -> str:
    try:
        return Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()[0]
    except OSError:
        return "gone"
