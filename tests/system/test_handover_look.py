"""Under the paper's protocol with cubic motions (`/policy/look_at_handover`), a whole handover on the
simulator runs the paper's look: the receiver waits until the giver holds the block out, the camera looks
at it, and the receiver takes it by its grasp of the block as seen (`find_handed_block`, `over_seen_grasp`,
`FLSPegTransfer_handover.py`, BerkeleyAutomation/FLSpegtransferHO), the giver holding it out where the
paper's does (`go_handover_traj`: `height_handover`, z -0.110 m in its frame, the tool along its base's z at
yaw 0); under pegbt's protocol it never looks and meets lower, the tool along the pegs' axis."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from trial_helpers import one_handover

from pegbt.evaluation.trial import TrialSpec, run_trial
from pegbt.executive.logfile import read_tick_log

HANDOVER_Z = -0.110  # m, `height_handover` (`dvrkPegTransferMotionHandOver.py`), z in the giver's frame


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
    meetings = [np.asarray(value) for _, _, key, value in parsed.writes if key == "/handover/meeting"]
    assert len(meetings) == 1
    upright = np.allclose(meetings[0][:3, :3], np.eye(3), atol=1e-9)
    at_height_handover = abs(meetings[0][2, 3] - HANDOVER_Z) < 1e-9
    assert upright == at_height_handover == bool(looks)
    if not looks:
        assert meetings[0][2, 3] < HANDOVER_Z - 0.005  # pegbt's meeting is lower
