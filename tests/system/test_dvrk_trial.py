"""End to end in real time: `pegbt run trees/unilateral.yaml --interface dvrk` against `pegbt sim --interface dvrk`,
judged from the simulator's own log (its world events), not from what the executive believes."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from pegbt.sim.process import SimProcess
from pegbt.workcell import UNILATERAL_ORDER


@pytest.mark.slow
def test_a_unilateral_trial_in_real_time_against_the_dvrk_interface_places_all_twelve(
    pegbt_cli, tmp_path: Path
):
    simlog = tmp_path / "sim.jsonl"
    simulator = SimProcess(["--physics", "dvrk-real", "--seed", "0", "--log", str(simlog)], interface="dvrk")
    try:
        run = pegbt_cli(
            "run",
            "trees/unilateral.yaml",
            "--interface",
            "dvrk",
            "--endpoint",
            simulator.endpoint,
            "--calibration",
            "skills/calibration/sim-dvrk-real",
            "--liveness",
            5,  # the simulator shares this loaded machine with the run: it may stall for a second
            "--log",
            tmp_path / "run.jsonl",
            "--quiet",
            timeout=600,
        )
    finally:
        simulator.stop()
    assert run.returncode == 0, run.stdout[-3000:] + run.stderr[-3000:]
    entries = [json.loads(line) for line in simlog.read_text().splitlines()]
    assert entries[0]["kind"] == "start" and entries[0]["interface"] == "dvrk"
    placed = [(entry["block"], entry["peg"]) for entry in entries if entry["kind"] == "place"]
    # every block ends on the peg it was carried to, in the reference order, and nothing was clipped or faulted
    assert [peg for _, peg in placed] == [goal for _, goal in UNILATERAL_ORDER]
    assert not [entry for entry in entries if entry["kind"] == "safety"]
    assert not [entry for entry in entries if entry["kind"] == "arm_state" and entry["state"] == "FAULT"]
    messages = [json.loads(line) for line in (tmp_path / "run.jsonl").read_text().splitlines()]
    assert any(record["type"] == "message" for record in messages)  # what the robot said is in the tick log
