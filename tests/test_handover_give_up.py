"""A giver that cannot pick its block gives the handover up once: it lets go, tells the receiver, and the
trial goes on."""

from __future__ import annotations

from pathlib import Path

from executive_helpers import with_shared_trees

from pegbt.evaluation.trial import TrialSpec, run_trial

REPO = Path(__file__).resolve().parents[1]


def one_handover(tmp_path: Path, regrasps: int = 0) -> Path:
    """Look, then hand the block on peg 1 from PSM2 to PSM1 for peg 7, with `regrasps` recoveries of the pick."""
    tree = tmp_path / "one-handover.yaml"
    with_shared_trees(tree.parent)
    tree.write_text(
        f"include: [shared/handover.yaml, shared/sense.yaml]\n"
        "tree:\n  sequence:\n"
        "    - subtree: {use: clear_view}\n"
        "    - parallel:\n        name: one handover\n        children:\n"
        f"          - force_success: {{name: g, child: {{subtree: {{use: give, args: {{giver: PSM2, receiver: PSM1, n: 1, pick: 1, place: 7, regrasps: {regrasps}, strays: [6]}}}}}}}}\n"
        "          - force_success: {name: r, child: {subtree: {use: receive, args: {receiver: PSM1, n: 1, place: 7, strays: [6]}}}}\n"
    )
    return tree


def test_a_giver_that_misses_gives_the_handover_up_once(tmp_path):
    faults = tmp_path / "misses.yaml"
    faults.write_text("world: {miss_probability: 1.0}\n")
    spec = TrialSpec(
        "handover", "optimized", 3, tmp_path / "one-handover.jsonl", faults, tree=one_handover(tmp_path)
    )
    record = run_trial(spec)
    assert record.transfers_attempted == 1  # begun once, not again and again while the jaw opens
    assert [transfer["succeeded"] for transfer in record.transfers] == [False]
    assert (
        record.trial_time_s < 20.0
    )  # the look, one missed pick, letting go: the receiver does not wait it out
