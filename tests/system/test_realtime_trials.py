"""Peg transfer in real time, end to end, each trial judged from its simulator's own log (its world events),
not from what the executive believes:

- `pegbt run trees/unilateral.yaml --interface dvrk` against `pegbt sim --interface dvrk` (the bridge's wire,
  the streaming camera);
- the same over a ROS 2 graph on rmw_zenoh with a Zivid: every cloud captured through `/capture`, its blocks
  searched at full resolution. One trial proves both claims: a trial over rmw_zenoh places every block
  (issue 13), and one with a Zivid does (issue 25);
- a trial against pegbt's own interface (`--endpoint auto`), the run on the wall clock.

The three run at once, each against its own simulator: a trial in real time waits on the wall clock for most
of its minute, so together they take about the minute one does, and each test judges its own."""

from __future__ import annotations

import json
from concurrent.futures import Future, ThreadPoolExecutor
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import pytest
from dvrk_trial_helpers import assert_every_block_placed_cleanly, unilateral_on_dvrk
from rmw_zenoh_helpers import zenoh_router

from pegbt.evaluation.trial import TrialRecord, TrialSpec, run_trial, truth_path
from pegbt.executive.logfile import read_tick_log
from pegbt.sim.log import read_sim_log

pytestmark = pytest.mark.slow


@dataclass(frozen=True)
class Trials:
    """The three trials' results: the dVRK interface's and the Zivid's simulator logs (their futures raise
    what their run's failure raised), and the trial on pegbt's interface, each with its folder."""

    dvrk: Future[list[dict[str, Any]]]
    zivid: Future[list[dict[str, Any]]]
    pegbt: TrialRecord
    folders: dict[str, Path]


@pytest.fixture(scope="module")
def trials(tmp_path_factory: pytest.TempPathFactory, pegbt_cli: Any) -> Trials:
    """The two dVRK-interface trials in threads (each a `pegbt run` child against a `pegbt sim` child), the
    one on pegbt's interface in this thread (its run handles signals), all at once."""
    folders = {name: tmp_path_factory.mktemp(name) for name in ("dvrk", "zivid", "pegbt")}
    with zenoh_router() as port, ThreadPoolExecutor(2) as pool:
        dvrk = pool.submit(unilateral_on_dvrk, pegbt_cli, folders["dvrk"])
        zivid = pool.submit(
            unilateral_on_dvrk,
            pegbt_cli,
            folders["zivid"],
            ["--camera", "zivid"],
            ["--ros2", "rmw_zenoh", "--camera", "zivid"],
            router=f"tcp/127.0.0.1:{port}",
        )
        log = folders["pegbt"] / "realtime.jsonl"
        record = run_trial(TrialSpec("unilateral", "optimized", 7, log, keep_log=True, realtime=True))
    return Trials(dvrk, zivid, record, folders)  # the pool waited for both before the router closed


def test_a_unilateral_trial_in_real_time_against_the_dvrk_interface_places_all_twelve(trials: Trials):
    entries = trials.dvrk.result()
    assert entries[0]["kind"] == "start" and entries[0]["interface"] == "dvrk"
    assert_every_block_placed_cleanly(entries)
    run = (trials.folders["dvrk"] / "run.jsonl").read_text().splitlines()
    messages = [json.loads(line) for line in run]
    assert any(record["type"] == "message" for record in messages)  # what the robot said is in the tick log


def test_a_unilateral_trial_over_rmw_zenoh_with_a_zivid_places_all_twelve(trials: Trials) -> None:
    entries = trials.zivid.result()
    assert entries[0]["kind"] == "start" and entries[0]["camera"] == "zivid"
    assert_every_block_placed_cleanly(entries)
    run = (trials.folders["zivid"] / "run.jsonl").read_text().splitlines()
    ticks = [json.loads(line) for line in run]
    assert ticks[0]["run"]["options"]["ros2"] == "rmw_zenoh", ticks[0]
    clouds = [
        r["bb"]["/cloud"]["repr"] for r in ticks if r.get("type") == "tick" and "/cloud" in r.get("bb", {})
    ]
    assert clouds, "every capture went through the Zivid's service"
    # the whole image, which block search reads at full resolution near the blocks
    assert all(cloud.startswith("ZividCloud(1200×1944 image") for cloud in clouds), clouds[:3]


def test_a_unilateral_trial_in_real_time_puts_every_block_back_home_as_the_simulator_logs_it(trials: Trials):
    record = trials.pegbt
    assert record.outcome == "success", record.error
    assert (record.transfers_attempted, record.transfers_succeeded) == (12, 12)
    assert record.arm_arm_collisions == 0

    log = trials.folders["pegbt"] / "realtime.jsonl"
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
