"""A bad bag given to the real `pegbt` process: one line naming the bag and the topic, never a traceback."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

from bag_helpers import stream_bag

REPO = Path(__file__).resolve().parents[2]


def test_the_cli_names_the_bag_and_topic(tmp_path):
    bag, _ = stream_bag(tmp_path)
    done = subprocess.run(
        [sys.executable, "-m", "pegbt", "sim2real", "diagnose", str(bag), "--phy", "/PSM1/nope"],
        check=False,
        capture_output=True,
        text=True,
        cwd=REPO,
        timeout=120,
    )
    assert done.returncode == 2 and "Traceback" not in done.stderr
    assert str(bag) in done.stderr and "no topic /PSM1/nope" in done.stderr
