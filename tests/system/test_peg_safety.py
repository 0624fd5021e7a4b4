"""Stopping safely: a halted motion stops its arm, a vanished endpoint ends the run with its cause, and a
block that is not where perception says fails the trial with the reason, all against the embedded simulator.
Trials run `pegbt run` in this process (`main`); only the dying endpoint's is a child process, for its exit status."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest
from executive_helpers import with_shared_trees

from pegbt.behaviours.resources.skills import SIMULATOR_CALIBRATION
from pegbt.cli import main
from pegbt.executive.logfile import read_tick_log
from pegbt.executive.runoptions import RunOptions
from pegbt.executive.session import run_tree_file
from pegbt.motion.kinematics import forward_kinematics
from pegbt.motion.limits import arm_settings
from pegbt.sim.process import SimProcess
from pegbt.transport import ArmClient, SimClock, connect

REPO = Path(__file__).resolve().parents[2]
SIMULATOR = ["--lockstep", "--physics", "dvrk-real"]


def log_why(log: Path, capsys: pytest.CaptureFixture[str]) -> str:
    """What `pegbt log why LOG` prints."""
    capsys.readouterr()
    assert main(["log", "why", str(log)]) == 0
    return capsys.readouterr().out


def test_halting_a_running_motion_stops_the_arm(tmp_path):
    tree = tmp_path / "halt.yaml"
    tree.write_text("tree:\n  timeout:\n    seconds: 0.7\n    child:\n      park: {name: park, arm: PSM1}\n")
    with SimProcess([*SIMULATOR, "--no-world"]) as sim:
        output = run_tree_file(
            RunOptions(tree, tmp_path / "halt.jsonl", {"endpoint": sim.endpoint, "condition": "uncalibrated"})
        )
        assert output.result.outcome == "failure"
        with connect([sim.endpoint]) as link:
            clock = SimClock(link)
            arm = ArmClient(link, "PSM1", clock=clock)
            arm.wait_until_ready(30.0)
            held = arm.setpoint_js.position.copy()
            clock.wait(1.0)
            assert np.allclose(arm.setpoint_js.position, held) and not arm.operating_state.is_busy
            tip = forward_kinematics(held)[:3, 3]
    home, start = arm_settings("PSM1").home_tip, forward_kinematics(np.array([0, 0, 0.12, 0, 0, 0.0]))[:3, 3]
    assert np.linalg.norm(tip - home) > 0.005 and np.linalg.norm(tip - start) > 0.005  # stopped on the way
    records = [json.loads(line) for line in (tmp_path / "halt.jsonl").read_text().splitlines()]
    halted = [
        change
        for record in records
        if record["type"] == "tick"
        for change in record["changes"]
        if change[1] == "RUNNING" and change[2] == "INVALID"
    ]
    assert halted and "parking" in halted[0][3]


def test_an_endpoint_that_dies_mid_trial_ends_the_run_with_its_cause(tmp_path, pegbt_cli, capsys):
    log = tmp_path / "crash.jsonl"
    with SimProcess([*SIMULATOR, "--crash-at", "6"]) as sim:
        run = pegbt_cli(
            "run",
            "trees/unilateral.yaml",
            "--endpoint",
            sim.endpoint,
            "--calibration",
            SIMULATOR_CALIBRATION,
            "--log",
            log,
            "--quiet",
        )
    assert run.returncode == 3 and "Traceback" not in run.stderr  # the endpoint was lost, not bad input
    assert "pegbt: error:" in run.stderr and "sim/step" in run.stderr
    why = log_why(log, capsys)
    assert "outcome: crash" in why and "no simulator answers on sim/step" in why
    assert "halted: crash" in why  # the motion under way was told to stop


def one_transfer(
    tmp_path: Path, world_faults: str, log: Path, capsys: pytest.CaptureFixture[str], protocol: str = "pegbt"
) -> tuple[int, str]:
    """Transfer 1 → 7 with PSM1 (one recovery allowed, no skipping) on a simulator injecting `world_faults`,
    under `protocol` (the paper's places at the unilateral's heights, the tree's name): `pegbt run`'s exit
    status and what it printed."""
    faults = tmp_path / "faults.yaml"
    faults.write_text(f"world: {world_faults}\n")
    tree = tmp_path / "unilateral.yaml"
    with_shared_trees(tree.parent)
    tree.write_text(
        "include: [shared/one_transfer.yaml, shared/sense.yaml]\n"
        "blackboard: {/policy/skip_failed_blocks: false, /PSM1/may_carry: true}\n"
        "tree:\n  sequence:\n"
        "    - subtree: {use: clear_view}\n"
        "    - subtree: {use: transfer_block, args: {arm: PSM1, pick: 1, place: 7, regrasps: 1}}\n"
    )
    capsys.readouterr()
    with SimProcess([*SIMULATOR, "--faults", str(faults)]) as sim:
        status = main(
            [
                "run",
                str(tree),
                "--endpoint",
                sim.endpoint,
                "--calibration",
                str(SIMULATOR_CALIBRATION),
                "--log",
                str(log),
                "--protocol",
                protocol,
                "--quiet",
            ]
        )
    printed = capsys.readouterr()
    return status, printed.out + printed.err


def test_a_block_that_slips_from_the_jaw_is_found_and_moved_again(tmp_path, capsys):
    log = tmp_path / "slip.jsonl"
    status, printed = one_transfer(
        tmp_path, "{slips: [{time: 0.2, arm: PSM1, after: {event: lift, arm: PSM1}}]}", log, capsys
    )
    assert status == 0, printed
    assert "transfers 1/1 succeeded" in printed
    why = log_why(log, capsys)
    assert "the block slipped from PSM1's jaw" in why and "it helped" in why


@pytest.mark.parametrize(
    ("protocol", "note", "recoveries"),
    [
        ("pegbt", "gave up after at most 1 recoveries", 1),
        ("paper", "gave up after its one attempt (recovery off)", 0),
    ],
)
def test_a_block_not_where_perception_says_fails_the_trial_with_the_reason(
    tmp_path, capsys, protocol, note, recoveries
):
    """The failed transfer's note says what its protocol allowed: the paper's moves each block once."""
    log = tmp_path / "miss.jsonl"
    status, printed = one_transfer(tmp_path, "{miss_probability: 1.0}", log, capsys, protocol)
    assert status == 1, printed
    assert "transfers 0/1 succeeded" in printed and note in printed
    assert "recoveries" not in printed.replace(note, "")  # the other protocol's note is not printed
    parsed = read_tick_log(log)
    looks_again = {index for index, node in enumerate(parsed.nodes) if node["name"] == "look again"}
    ran = [
        change for change in parsed.transitions if change.node in looks_again and change.after == "SUCCESS"
    ]
    assert len(ran) == recoveries
    why = log_why(log, capsys)
    assert "outcome: failure" in why and "policy says skip it" in why
    assert "jaw closed to" in why and "on nothing" in why  # the pick's reason, as the recoveries saw it
