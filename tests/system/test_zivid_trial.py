"""End to end in real time with a Zivid: `pegbt run trees/unilateral.yaml --interface dvrk --camera zivid` against
`pegbt sim --interface dvrk --camera zivid`, every cloud captured through `/capture`, its blocks searched at full resolution, judged from
the simulator's own log."""

from __future__ import annotations

import json
from pathlib import Path

from dvrk_trial_helpers import assert_every_block_placed_cleanly, unilateral_on_dvrk


def test_a_unilateral_trial_with_a_zivid_places_all_twelve(pegbt_cli, tmp_path: Path) -> None:
    entries = unilateral_on_dvrk(pegbt_cli, tmp_path, ["--camera", "zivid"], ["--camera", "zivid"])
    assert entries[0]["kind"] == "start" and entries[0]["camera"] == "zivid"
    assert_every_block_placed_cleanly(entries)
    ticks = [json.loads(line) for line in (tmp_path / "run.jsonl").read_text().splitlines()]
    clouds = [
        r["bb"]["/cloud"]["repr"] for r in ticks if r.get("type") == "tick" and "/cloud" in r.get("bb", {})
    ]
    assert clouds, "every capture went through the Zivid's service"
    # the whole image, which block search reads at full resolution near the blocks
    assert all(cloud.startswith("ZividCloud(1200×1944 image") for cloud in clouds), clouds[:3]
