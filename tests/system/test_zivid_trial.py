"""End to end in real time with a Zivid on a ROS 2 graph on rmw_zenoh: `pegbt run trees/unilateral.yaml
--interface dvrk --ros2 rmw_zenoh --camera zivid` against `pegbt sim --interface dvrk --camera zivid` on the
same router, every cloud captured through `/capture`, its blocks searched at full resolution, judged from the
simulator's own log.

One whole trial proves both claims: a trial over rmw_zenoh places every block (issue 13), and one with a
Zivid does (issue 25); the bridge's wire and the streaming camera have theirs in `test_dvrk_trial.py`."""

from __future__ import annotations

import json
from pathlib import Path

import pytest
from dvrk_trial_helpers import assert_every_block_placed_cleanly, unilateral_on_dvrk


@pytest.mark.slow
def test_a_unilateral_trial_over_rmw_zenoh_with_a_zivid_places_all_twelve(
    pegbt_cli, router, tmp_path: Path
) -> None:
    graph = f"tcp/127.0.0.1:{router}"
    run_options = ["--ros2", "rmw_zenoh", "--camera", "zivid"]
    entries = unilateral_on_dvrk(pegbt_cli, tmp_path, ["--camera", "zivid"], run_options, router=graph)
    assert entries[0]["kind"] == "start" and entries[0]["camera"] == "zivid"
    assert_every_block_placed_cleanly(entries)
    ticks = [json.loads(line) for line in (tmp_path / "run.jsonl").read_text().splitlines()]
    assert ticks[0]["run"]["options"]["ros2"] == "rmw_zenoh", ticks[0]
    clouds = [
        r["bb"]["/cloud"]["repr"] for r in ticks if r.get("type") == "tick" and "/cloud" in r.get("bb", {})
    ]
    assert clouds, "every capture went through the Zivid's service"
    # the whole image, which block search reads at full resolution near the blocks
    assert all(cloud.startswith("ZividCloud(1200×1944 image") for cloud in clouds), clouds[:3]
