"""A unilateral trial in real time through the simulator's dVRK interface, as several system tests run it
(over the bridge's wire or rmw_zenoh, with the streaming camera or a Zivid), and what they all check of it."""

from __future__ import annotations

import json
from collections.abc import Callable, Sequence
from pathlib import Path
from typing import Any

from pegbt.sim.process import SimProcess
from pegbt.workcell import UNILATERAL_ORDER


def unilateral_on_dvrk(
    pegbt_cli: Callable[..., Any],
    tmp_path: Path,
    sim_options: Sequence[str] = (),
    run_options: Sequence[object] = (),
    router: str | None = None,
) -> list[dict[str, Any]]:
    """`pegbt run trees/unilateral.yaml --interface dvrk` against `pegbt sim --interface dvrk` (seed 0, the
    `dvrk-real` physics and the calibration that compensates it), each with its extra options; the run must
    succeed. The simulator's log, its ground truth, entry by entry."""
    simlog = tmp_path / "sim.jsonl"
    simulator = SimProcess(
        ["--physics", "dvrk-real", "--seed", "0", *sim_options, "--log", str(simlog)],
        interface="dvrk",
        router=router,
    )
    try:
        run = pegbt_cli(
            "run",
            "trees/unilateral.yaml",
            "--interface",
            "dvrk",
            *run_options,
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
    return [json.loads(line) for line in simlog.read_text().splitlines()]


def assert_every_block_placed_cleanly(entries: list[dict[str, Any]]) -> None:
    """Every block ends on the peg it was carried to, in the reference order; nothing clipped, no FAULT."""
    placed = [entry["peg"] for entry in entries if entry["kind"] == "place"]
    assert placed == [goal for _, goal in UNILATERAL_ORDER]
    assert not [entry for entry in entries if entry["kind"] == "safety"]
    assert not [entry for entry in entries if entry["kind"] == "arm_state" and entry["state"] == "FAULT"]
