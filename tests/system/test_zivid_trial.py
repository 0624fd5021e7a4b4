"""End to end in real time with a Zivid: `pegbt run trees/unilateral.yaml --interface dvrk --camera zivid` against
`pegbt sim --interface dvrk --camera zivid`, every cloud captured through `/capture` and thinned, judged from
the simulator's own log."""

from __future__ import annotations

import json
from pathlib import Path


from pegbt.sim.process import SimProcess
from pegbt.workcell import UNILATERAL_ORDER


def test_a_unilateral_trial_with_a_zivid_places_all_twelve(pegbt_cli, tmp_path: Path) -> None:
    simlog = tmp_path / "sim.jsonl"
    simulator = SimProcess(
        ["--physics", "dvrk-real", "--seed", "0", "--camera", "zivid", "--log", str(simlog)], interface="dvrk"
    )
    try:
        run = pegbt_cli(
            "run",
            "trees/unilateral.yaml",
            "--interface",
            "dvrk",
            "--camera",
            "zivid",
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
    assert entries[0]["kind"] == "start" and entries[0]["camera"] == "zivid"
    placed = [(entry["block"], entry["peg"]) for entry in entries if entry["kind"] == "place"]
    assert [peg for _, peg in placed] == [goal for _, goal in UNILATERAL_ORDER]
    assert not [entry for entry in entries if entry["kind"] == "safety"]
    assert not [entry for entry in entries if entry["kind"] == "arm_state" and entry["state"] == "FAULT"]
    ticks = [json.loads(line) for line in (tmp_path / "run.jsonl").read_text().splitlines()]
    clouds = [
        r["bb"]["/cloud"]["shape"] for r in ticks if r.get("type") == "tick" and "/cloud" in r.get("bb", {})
    ]
    assert clouds, "every capture went through the Zivid's service"
    # a quarter of a full frame's ≈127 k valid points: every 2nd row and column, NaN dropped
    assert all(25_000 < rows < 45_000 and columns == 3 for rows, columns in clouds)
