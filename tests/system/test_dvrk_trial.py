"""End to end in real time: `pegbt run trees/unilateral.yaml --interface dvrk` against `pegbt sim --interface dvrk`,
judged from the simulator's own log (its world events), not from what the executive believes."""

from __future__ import annotations

import json
from pathlib import Path

import pytest
from dvrk_trial_helpers import assert_every_block_placed_cleanly, unilateral_on_dvrk


@pytest.mark.slow
def test_a_unilateral_trial_in_real_time_against_the_dvrk_interface_places_all_twelve(
    pegbt_cli, tmp_path: Path
):
    entries = unilateral_on_dvrk(pegbt_cli, tmp_path)
    assert entries[0]["kind"] == "start" and entries[0]["interface"] == "dvrk"
    assert_every_block_placed_cleanly(entries)
    messages = [json.loads(line) for line in (tmp_path / "run.jsonl").read_text().splitlines()]
    assert any(record["type"] == "message" for record in messages)  # what the robot said is in the tick log
