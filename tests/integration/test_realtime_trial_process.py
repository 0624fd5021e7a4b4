"""`pegbt eval --interface dvrk` without real time is refused by the real process: one line and a non-zero
exit."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

REPO = Path(__file__).resolve().parents[2]


def test_eval_refuses_the_dvrk_interface_without_realtime(tmp_path):
    run = subprocess.run(
        [sys.executable, "-m", "pegbt", "eval", "--variant", "unilateral", "--trials", "1"]
        + ["--interface", "dvrk", "--out", str(tmp_path / "out")],
        capture_output=True,
        text=True,
        cwd=REPO,
        timeout=120,
        check=False,
    )
    assert run.returncode == 2 and run.stderr.count("\n") == 1 and "Traceback" not in run.stderr
    assert "--interface dvrk runs in real time" in run.stderr
    assert not (tmp_path / "out").exists()  # nothing ran
