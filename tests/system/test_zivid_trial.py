"""End to end in real time with a Zivid: `pegbt run trees/unilateral.yaml --interface dvrk --camera zivid` against
`pegbt sim --interface dvrk --camera zivid`, every cloud captured through `/capture` and thinned, judged from
the simulator's own log."""

from __future__ import annotations

import json
from pathlib import Path

import pytest
from dvrk_trial_helpers import assert_every_block_placed_cleanly, unilateral_on_dvrk


@pytest.mark.slow
def test_a_unilateral_trial_with_a_zivid_places_all_twelve(pegbt_cli, tmp_path: Path) -> None:
    entries = unilateral_on_dvrk(pegbt_cli, tmp_path, ["--camera", "zivid"], ["--camera", "zivid"])
    assert entries[0]["kind"] == "start" and entries[0]["camera"] == "zivid"
    assert_every_block_placed_cleanly(entries)
    ticks = [json.loads(line) for line in (tmp_path / "run.jsonl").read_text().splitlines()]
    clouds = [
        r["bb"]["/cloud"]["shape"] for r in ticks if r.get("type") == "tick" and "/cloud" in r.get("bb", {})
    ]
    assert clouds, "every capture went through the Zivid's service"
    # a quarter of a full frame's ≈127 k valid points: every 2nd row and column, NaN dropped
    assert all(25_000 < rows < 45_000 and columns == 3 for rows, columns in clouds)
