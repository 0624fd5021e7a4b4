"""A block the giver drops beside a peg, where every grasp the receiver could take it from would put the
giver's tool on that peg: the giver picks it by a grasp clear of the pegs, sets it back on its start peg,
looks again and hands it over from there (`trees/shared/set_back.yaml`). As seed 1001's handover 2 with
`--inject-faults` (docs/internals/motion.md): the block from peg 0 slips on its carry to the meeting point
and falls off peg 6's top onto the board, 11 mm beside peg 3 (looked at: [54.7, 29.7] mm)."""

from __future__ import annotations

from trial_helpers import one_handover

from pegbt.evaluation.trial import TrialSpec, run_trial, truth_path
from pegbt.sim.log import read_sim_log

# s after the giver's block cleared peg 0 (seed 1001: at 3.31 s), on the carry to the meeting point
SLIP = 0.70


def test_a_dropped_block_with_no_clear_grasp_to_hand_over_is_set_back_on_its_peg_and_handed_over(tmp_path):
    faults = tmp_path / "slip.yaml"
    faults.write_text(f"world: {{slips: [{{time: {SLIP}, arm: PSM2, after: {{event: lift, arm: PSM2}}}}]}}\n")
    spec = TrialSpec(
        "handover",
        "optimized",
        1001,
        tmp_path / "set-back.jsonl",
        faults,
        keep_log=True,
        tree=one_handover(tmp_path, regrasps=2, pick=0, place=6),
    )
    record = run_trial(spec)
    truth = read_sim_log(truth_path(spec.log))
    assert [(e["kind"], e["arm"], e["peg"]) for e in truth if e["kind"] in ("drop", "place")] == [
        ("drop", "PSM2", None),
        ("place", "PSM2", 0),  # set back on its start peg
        ("place", "PSM1", 6),
    ]
    assert [transfer["succeeded"] for transfer in record.transfers] == [True]
    assert [(fault["kind"], fault["recovered"]) for fault in record.faults] == [("slip", True)]
    assert [e for e in truth if e["kind"] == "collision"] == []  # the tool never met a peg, nor the other arm
    assert (record.commands_clipped, record.arm_faults) == (0, 0)
