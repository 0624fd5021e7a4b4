"""Recoveries between the two sides of a handover, on the embedded simulator with faults at chosen times:
a slip as the receiver's jaw closes, a slip while the receiver waits above the block, and a receiver that
fetches its dropped block while the giver brings the next one."""

from __future__ import annotations

from pathlib import Path

from executive_helpers import with_shared_trees
from trial_helpers import one_handover

from pegbt.evaluation.trial import TrialSpec, run_trial

# When the slips fall, as (seconds after, the world event): in the window the test names whatever path led
# there (seed 3).
RECEIVER_GRIPS = (0.03, "{event: grasp, arm: PSM1}")  # the receiver's check of its grip ends 0.09 s after it
RECEIVER_CARRIES = (0.7, "{event: release, arm: PSM2}")  # it carries the block off 0.51 s to 1.17 s after


def two_handovers(tmp_path: Path) -> Path:
    """Look, then hand the blocks on pegs 1 and 0 from PSM2 to PSM1 for pegs 7 and 6, pipelined: giver and
    receiver loop over one list."""
    tree = tmp_path / "two-handovers.yaml"
    with_shared_trees(tree.parent)
    tree.write_text(
        "include: [shared/handover.yaml, shared/sense.yaml]\n"
        "lists: {two: [{pick: 1, place: 7, strays: [6]}, {pick: 0, place: 6, strays: [6]}]}\n"
        "tree:\n  sequence:\n"
        "    - subtree: {use: clear_view}\n"
        "    - parallel:\n        name: two handovers\n        children:\n"
        "          - for_each: {name: PSM2 gives, list: two, use: give, args: {giver: PSM2, receiver: PSM1}, on_failure: continue}\n"
        "          - for_each: {name: PSM1 receives, list: two, use: receive, args: {receiver: PSM1, giver: PSM2}, on_failure: continue}\n"
    )
    return tree


def trial(tmp_path: Path, slip: tuple[float, str], arm: str, tree: Path):
    faults = tmp_path / "slip.yaml"
    faults.write_text(f"world: {{slips: [{{time: {slip[0]}, arm: {arm}, after: {slip[1]}}}]}}\n")
    return run_trial(TrialSpec("handover", "optimized", 3, tmp_path / "trial.jsonl", faults, tree=tree))


def test_a_giver_whose_block_slips_as_the_receiver_grips_it_lets_the_receiver_have_it(tmp_path):
    """The giver sees its jaw close (a slip) while the receiver's jaw already holds the block: once the
    receiver's close is checked it holds the block, so the giver lets go and the handover goes on."""
    record = trial(tmp_path, RECEIVER_GRIPS, "PSM2", one_handover(tmp_path, regrasps=2))
    assert [fault["kind"] for fault in record.faults] == ["slip"] and record.faults[0]["recovered"]
    assert [transfer["succeeded"] for transfer in record.transfers] == [True]
    assert record.trial_time_s < 9.0  # no withdrawal, no fetching again: it was a handover all along
    assert record.arm_arm_collisions == 0


def test_a_receiver_fetches_its_dropped_block_while_the_giver_holds_the_next_one_back(tmp_path):
    """The receiver's block slips as it carries it off: it fetches it from where it fell while the giver picks
    the next block and plans that handover (in keys of its own: it must not touch the grasp the receiver
    fetches with), and the giver brings it to the meeting point only once the receiver is ready for it."""
    record = trial(tmp_path, RECEIVER_CARRIES, "PSM1", two_handovers(tmp_path))
    assert [fault["kind"] for fault in record.faults] == ["slip"] and record.faults[0]["recovered"]
    assert [transfer["succeeded"] for transfer in record.transfers] == [True, True]
    assert record.arm_arm_collisions == 0
