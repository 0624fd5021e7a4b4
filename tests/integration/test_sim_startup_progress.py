"""A simulator child's start-up is bounded by its progress: on a loaded machine a slow but steady start-up
succeeds, while a child that stops progressing, or exits, is one clear error naming the last stage reached."""

from __future__ import annotations

import sys
import textwrap
from pathlib import Path

import pytest

from pegbt.errors import PegbtError
from pegbt.sim import process

BOUND = 1.5  # s the fake child may take to reach its next stage


def _fake_sim(tmp_path: Path, monkeypatch: pytest.MonkeyPatch, body: str) -> None:
    """Make `SimProcess` start a script in place of `python -m pegbt sim`: it ignores its arguments, prints
    stages as `pegbt sim --report-stages` does, paced by `body`."""
    script = tmp_path / "fake_sim.py"
    script.write_text(
        f"#!{sys.executable}\nimport sys, time\n"
        "def stage(name, after):\n"
        "    time.sleep(after)\n"
        "    print(f'pegbt sim: reached {name}', flush=True)\n" + textwrap.dedent(body)
    )
    script.chmod(0o755)
    monkeypatch.setattr(sys, "executable", str(script))
    monkeypatch.setattr(process, "STAGE_TIMEOUT", BOUND)


def test_a_slow_but_steady_start_up_longer_than_the_bound_starts(tmp_path, monkeypatch):
    """Six stages 0.3 s apart: 1.8 s in all, more than the bound, none of them slower than it."""
    _fake_sim(
        tmp_path,
        monkeypatch,
        """
        for name in ("started", "camera library loaded", "world built", "session open", "endpoint built"):
            stage(name, 0.3)
        time.sleep(0.3)
        print("pegbt sim: serving PSM1, PSM2 on tcp/127.0.0.1:1 (lockstep)", flush=True)
        sys.stdin.read()
        """,
    )
    with process.SimProcess() as sim:
        assert sim.process.poll() is None


def test_a_child_that_stops_progressing_is_killed_naming_its_last_stage(tmp_path, monkeypatch):
    _fake_sim(
        tmp_path,
        monkeypatch,
        """
        stage("started", 0)
        stage("camera library loaded", 0)
        print("loading meshes", file=sys.stderr, flush=True)
        time.sleep(600)
        """,
    )
    with pytest.raises(
        PegbtError,
        match=r"pegbt sim did not start: no progress within 1.5 s after 'camera library loaded': loading meshes$",
    ):
        process.SimProcess()


def test_a_child_that_exits_during_start_up_says_where_and_why(tmp_path, monkeypatch):
    _fake_sim(
        tmp_path,
        monkeypatch,
        """
        stage("started", 0)
        print("pegbt: --faults: no such file", file=sys.stderr, flush=True)
        sys.exit(2)
        """,
    )
    with pytest.raises(
        PegbtError,
        match=r"did not start: it exited \(status 2\) after 'started': pegbt: --faults: no such file$",
    ):
        process.SimProcess()
