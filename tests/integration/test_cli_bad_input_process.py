"""Bad input to a command run as a real process is one line and a non-zero exit, never a traceback; a reader
that stops early (a closed pipe) ends the command quietly. The in-process cases are in
`tests/unit/test_cli_bad_input.py`."""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

from pegbt.cli import BROKEN_PIPE_STATUS

REPO = Path(__file__).resolve().parents[2]
EXAMPLE = REPO / "trees" / "example.yaml"


def _command(*args: str, **options: object) -> subprocess.Popen[str]:
    env = dict(os.environ, PYTHONPATH=str(REPO))
    return subprocess.Popen(
        [sys.executable, "-m", "pegbt", *args],
        cwd=REPO,
        env=env,
        text=True,
        stderr=subprocess.PIPE,
        **options,
    )


def test_a_command_run_as_a_process_refuses_a_bad_number_in_one_line():
    process = _command("run", str(EXAMPLE), "--period", "nan", stdout=subprocess.PIPE)
    out, err = process.communicate(timeout=60)
    assert (
        process.returncode == 2
        and err.strip() == "pegbt: error: --period: must be a finite number > 0, got nan"
    )


def test_a_reader_that_stops_early_ends_the_command_quietly():
    process = _command("tree", "schema", stdout=subprocess.PIPE)
    process.stdout.close()  # like `| head` having read what it wanted, before the command writes
    err = process.stderr.read()
    assert process.wait(timeout=60) == BROKEN_PIPE_STATUS and err == ""
