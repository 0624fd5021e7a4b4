"""Under the paper's protocol with cubic motions (`/policy/look_at_handover`), a whole handover on the
simulator runs the paper's look: the receiver waits until the giver holds the block out, the camera looks
at it, and the receiver takes it by its grasp of the block as seen (`find_handed_block`, `over_seen_grasp`,
`FLSPegTransfer_handover.py`, BerkeleyAutomation/FLSpegtransferHO); under pegbt's protocol it never looks."""

from __future__ import annotations

from pathlib import Path

import pytest
from trial_helpers import one_handover

from pegbt.evaluation.trial import TrialSpec, run_trial
from pegbt.executive.logfile import read_tick_log


@pytest.mark.parametrize(("protocol", "looks"), [("paper", 1), ("pegbt", 0)])
def test_the_receiver_takes_the_block_where_the_look_sees_it_held_out(
    tmp_path: Path, protocol: str, looks: int
) -> None:
    log = tmp_path / "one-handover.jsonl"
    record = run_trial(
        TrialSpec(
            "handover", "uncalibrated", 3, log, keep_log=True, tree=one_handover(tmp_path), protocol=protocol
        )
    )
    parsed = read_tick_log(log)
    types = {
        index: node["type"]
        for index, node in enumerate(parsed.nodes)
        if node["type"] in ("find_handed_block", "over_seen_grasp")
        or (node["type"] == "grasp" and "/take it/" in node["path"])  # the receiver's, not a fetch's
    }
    ended: dict[str, list[str]] = {}
    for change in parsed.transitions:
        if change.node in types and change.after in ("SUCCESS", "FAILURE"):
            ended.setdefault(types[change.node], []).append(change.after)
    assert ended.get("find_handed_block", []) == ["SUCCESS"] * looks
    assert ended.get("over_seen_grasp", []) == ["SUCCESS"] * looks
    assert ended["grasp"] == ["SUCCESS"]  # it took the block the first time
    assert [transfer["arms"] for transfer in record.transfers] == ["PSM2→PSM1"]
