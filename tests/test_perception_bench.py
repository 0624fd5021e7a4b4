"""`pegbt bench perception` is registered and reachable from the command line."""

import os
import subprocess
import sys
from pathlib import Path

from pegbt.bench import load_benchmark
from pegbt.bench.perception import run

ROOT = Path(__file__).resolve().parents[1]


def test_the_perception_benchmark_is_listed_by_the_command_line():
    env = {**os.environ, "PYTHONPATH": str(ROOT)}
    listed = subprocess.run([sys.executable, "-m", "pegbt", "bench"], capture_output=True, text=True, env=env, cwd=ROOT)
    assert listed.returncode == 0 and "perception" in listed.stdout.split()
    assert load_benchmark("perception") is run
