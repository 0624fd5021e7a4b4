"""Stops: SIGTERM and SIGINT halt the tree, write the halt and end records and exit with their own
status; a stop is a command the endpoint always accepts."""

from __future__ import annotations

import json
import signal
import time
from pathlib import Path

import pytest

LONG_WAIT = (
    "tree:\n  sequence:\n    children:\n      - log: {message: started}\n      - wait: {seconds: 600.0}\n"
)


def _records(path) -> list[dict]:
    return [json.loads(line) for line in path.read_text().splitlines() if line.endswith("}")]


@pytest.mark.parametrize(("signum", "status"), [(signal.SIGTERM, 143), (signal.SIGINT, 130)])
def test_a_signal_halts_the_tree_writes_halt_and_end_and_exits_with_its_own_status(
    tmp_path, pegbt_cli, signum, status
):
    tree, log = tmp_path / "wait.yaml", tmp_path / "run.jsonl"
    tree.write_text(LONG_WAIT)
    process = pegbt_cli.start("run", tree, "--log", log, "--quiet")
    deadline = time.monotonic() + 60
    while not (log.exists() and any(r.get("type") == "tick" for r in _records(log))):
        assert process.poll() is None and time.monotonic() < deadline, process.communicate()
        time.sleep(0.1)
    process.send_signal(signum)
    _, stderr = process.communicate(timeout=60)
    assert process.returncode == status
    assert f"interrupted by {signal.Signals(signum).name}" in stderr and "Traceback" not in stderr
    records = _records(log)
    halt = [r for r in records if r["type"] == "halt"]
    assert halt and halt[0]["reason"] == "interrupt"
    assert any(change[2] == "RUNNING" and change[3] for change in halt[0]["changes"]) or halt[0]["changes"]
    assert records[-1]["type"] == "end" and records[-1]["outcome"] == "interrupted"


def test_nothing_listening_names_the_address_tried(tmp_path, short_connect_waits, capsys):
    from pegbt.cli import main
    from pegbt.sim.process import free_port

    address = f"tcp/127.0.0.1:{free_port()}"
    tree = Path(__file__).resolve().parents[2] / "trees" / "unilateral.yaml"
    assert main(["run", str(tree), "--endpoint", address, "--log", str(tmp_path / "x.jsonl")]) == 3
    stderr = capsys.readouterr().err
    assert address in stderr and "Traceback" not in stderr


@pytest.mark.parametrize("second", [signal.SIGINT, signal.SIGTERM])
def test_a_second_stop_while_the_simulator_closes_quits_it_at_once(tmp_path, pegbt_cli, second):
    """`timeout -s INT` signals the process and then its group: two stops a moment apart, as a user who
    presses Ctrl-C again does. The second, landing while the simulator closes its recording and session,
    left it waiting on zenoh's threads for ever."""
    from pegbt.sim.process import free_port

    process = pegbt_cli.start(
        "sim",
        "--listen",
        f"tcp/127.0.0.1:{free_port()}",
        "--priority",
        "normal",
        "--no-world",
        "--record",
        tmp_path / "sim.mcap",
    )
    assert process.stdout is not None and "serving" in process.stdout.readline()
    process.send_signal(signal.SIGINT)
    time.sleep(0.01)
    process.send_signal(second)
    _, stderr = process.communicate(timeout=20)
    assert process.returncode in (0, 128 + second) and "Traceback" not in stderr
