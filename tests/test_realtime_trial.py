"""Peg transfer in real time: a trial against `pegbt sim` in real time (not lockstep), the run on the wall
clock, judged by the simulator's own log; `--clock` and `--interface` as `pegbt run` and `pegbt eval`
take them."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import pytest

from pegbt.errors import PegbtError
from pegbt.evaluation.trial import TrialSpec, run_options, run_trial, simulator_args, truth_path
from pegbt.executive.logfile import read_tick_log
from pegbt.executive.runoptions import RunOptions
from pegbt.executive.session import run_tree_file
from pegbt.sim.log import read_sim_log

REPO = Path(__file__).resolve().parents[1]


@pytest.mark.slow
def test_a_unilateral_trial_in_real_time_puts_every_block_back_home_as_the_simulator_logs_it(tmp_path):
    log = tmp_path / "realtime.jsonl"
    record = run_trial(TrialSpec("unilateral", "optimized", 7, log, keep_log=True, realtime=True))
    assert record.outcome == "success", record.error
    assert (record.transfers_attempted, record.transfers_succeeded) == (12, 12)
    assert record.arm_arm_collisions == 0

    entries = read_sim_log(truth_path(log))  # the simulator's file, not the executive's beliefs
    assert entries[0]["kind"] == "start" and entries[0]["mode"] == "realtime"
    resting = {}  # block -> the peg it last came to rest on
    for entry in entries:
        if entry["kind"] in ("place", "drop") and entry.get("peg") is not None:
            resting[entry["block"]] = entry["peg"]
    assert resting == {block: block for block in range(6)}  # there and back: each on its own peg again
    lifts = [entry for entry in entries if entry["kind"] == "lift"]
    assert len(lifts) >= 12

    ticks = read_tick_log(log)
    assert ticks.header["clock"] == "wall" and ticks.outcome == "success"
    assert ticks.end["work"]["jobs"] > 12  # perception and planning ran off the tick


def test_a_robot_cannot_run_on_a_clock_that_only_moves_when_asked(tmp_path):
    with pytest.raises(PegbtError, match="--clock.*manual clock"):
        run_tree_file(RunOptions(REPO / "trees" / "unilateral.yaml", tmp_path / "run.jsonl", clock="manual"))


def test_eval_passes_realtime_and_the_interface_to_the_simulator_and_the_run(tmp_path):
    spec = TrialSpec("unilateral", "optimized", 3, tmp_path / "t.jsonl", realtime=True, interface="dvrk")
    args = simulator_args(spec, tmp_path / "truth.jsonl")
    assert "--lockstep" not in args and args[args.index("--interface") + 1] == "dvrk"
    assert run_options(spec, "tcp/127.0.0.1:7447")["interface"] == "dvrk"
    lockstep = simulator_args(TrialSpec("unilateral", "optimized", 3, tmp_path / "t.jsonl"), tmp_path / "x")
    assert "--lockstep" in lockstep and "--interface" not in lockstep


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
