"""Peg transfer in real time: a trial against `pegbt sim` in real time (not lockstep), the run on the wall
clock, judged by the simulator's own log."""

from __future__ import annotations

import pytest

from pegbt.evaluation.trial import TrialSpec, run_trial, truth_path
from pegbt.executive.logfile import read_tick_log
from pegbt.sim.log import read_sim_log


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
