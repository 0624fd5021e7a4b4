"""A recording truncated while `pegbt sim2real diagnose` reads it: the diagnosis either reports on what it
read before (its private copy) or exits with pegbt's error naming the file, never killed by a signal
(mapping the file itself, it died of SIGBUS at the first page past the file's new end)."""

from __future__ import annotations

import os
import time
from pathlib import Path

import pytest

from pegbt.sim2real.synth import generate, write_synthetic

ARRAY = "q_phy.npy"


def _reading(pid: int, array: Path) -> bool:
    """Whether the process has `array` open or mapped, or has already copied a recording array."""
    try:
        maps = Path(f"/proc/{pid}/maps").read_text()
        opened = [os.readlink(f"/proc/{pid}/fd/{fd}") for fd in os.listdir(f"/proc/{pid}/fd")]
    except OSError:  # it ended, or closed a file between the listing and the reading
        return False
    return str(array) in maps or str(array) in opened or "pegbt-npy-" in maps


@pytest.mark.slow  # a two-minute recording made, and diagnosed in a child: 8 to 18 s
def test_a_recording_truncated_under_a_diagnosis_is_reported_not_a_crash(tmp_path: Path, pegbt_cli) -> None:
    folder, _ = write_synthetic(generate("weak", 0, seconds=120.0), tmp_path / "synth")
    array = (folder / ARRAY).resolve()
    child = pegbt_cli.start("sim2real", "diagnose", folder, "--bootstrap", "0", "--out", tmp_path / "out")
    deadline = time.monotonic() + 120
    while child.poll() is None and not _reading(child.pid, array) and time.monotonic() < deadline:
        time.sleep(0.005)
    os.truncate(array, 1000)  # the header and a few samples left
    _, stderr = child.communicate(timeout=300)
    assert child.returncode in (0, 2), f"ended by signal {-child.returncode}: {stderr[-2000:]}"
    assert "Traceback" not in stderr
    if child.returncode == 2:
        assert str(folder / ARRAY) in stderr
    else:
        assert (tmp_path / "out" / "report.json").is_file()
