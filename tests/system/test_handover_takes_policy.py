"""A receiver that misses the block held out takes it again only where the policy recovers: under the
paper's protocol (`/policy/recover_lost_blocks` false) it takes it once, as the phase simulator plays the
paper's robot (`exchange.hand_over`)."""

from __future__ import annotations

from pathlib import Path

import pytest
from trial_helpers import one_handover

from pegbt.evaluation.trial import TrialSpec, run_trial
from pegbt.executive.logfile import read_tick_log
from pegbt.executive.phases import retried


@pytest.mark.parametrize(("protocol", "takes", "placed"), [("pegbt", 2, True), ("paper", 1, False)])
def test_a_receiver_takes_the_block_again_only_where_the_policy_recovers(
    tmp_path: Path, protocol: str, takes: int, placed: bool
) -> None:
    faults = tmp_path / "miss.yaml"
    faults.write_text(
        "world: {miss_attempts: [1]}\n"
    )  # the giver's pick holds, the receiver's first take misses
    log = tmp_path / "one-handover.jsonl"
    tree = one_handover(tmp_path)
    record = run_trial(TrialSpec("handover", "optimized", 3, log, faults, True, tree, protocol=protocol))
    assert [fault["kind"] for fault in record.faults] == ["grasp miss"]
    assert [transfer["succeeded"] for transfer in record.transfers] == [placed]
    parsed = read_tick_log(log)
    receiver_grasps = {
        index
        for index, node in enumerate(parsed.nodes)
        if node["type"] == "grasp" and node["params"].get("arm") == "PSM1"
    }
    ended = [c for c in parsed.transitions if c.node in receiver_grasps and c.after in ("SUCCESS", "FAILURE")]
    assert len(ended) == takes
    assert retried(parsed) == ({1} if takes > 1 else set())  # not a first try: no first-try time
