"""A block that slips from the giver's jaw while it holds it out at the meeting point: the giver notices,
withdraws, fetches the block from where it fell and holds it out again, and the receiver takes it then."""

from __future__ import annotations

from trial_helpers import one_handover

from pegbt.evaluation.trial import TrialSpec, run_trial

# s after the giver's block cleared its peg (seed 3: at 3.45 s): the giver has held it out at the meeting point
# since 4.10 s, the receiver closes on it at 4.23 s
HELD_OUT = 0.71


def test_a_block_slipping_at_the_meeting_point_is_fetched_again_and_handed_over(tmp_path):
    faults = tmp_path / "slip.yaml"
    faults.write_text(
        f"world: {{slips: [{{time: {HELD_OUT}, arm: PSM2, after: {{event: lift, arm: PSM2}}}}]}}\n"
    )
    spec = TrialSpec(
        "handover", "optimized", 3, tmp_path / "slip.jsonl", faults, tree=one_handover(tmp_path, regrasps=2)
    )
    record = run_trial(spec)
    assert [fault["kind"] for fault in record.faults] == [
        "slip"
    ]  # it befell the block held out, not another moment
    assert [transfer["succeeded"] for transfer in record.transfers] == [True]
    assert record.faults[0]["recovered"]
