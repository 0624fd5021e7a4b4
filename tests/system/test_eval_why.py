"""Failure analysis: on seeded faulty trials, `pegbt log why` names the step and cause that the simulator's
ground-truth event log confirms, and injected faults are counted with whether the trial got over them."""

from __future__ import annotations

import re
import subprocess
import sys
from pathlib import Path

import pytest
from executive_helpers import with_shared_trees
from trial_helpers import short_task

from pegbt.evaluation.trial import TrialSpec, run_trial

REPO = Path(__file__).resolve().parents[2]
# A slip 0.3 s after PSM1's block cleared its peg: in the carry whatever the approach took (seed 3: it clears
# peg 1 at 3.91 s and puts the block on peg 7 at 4.87 s)
CARRYING = "{time: 0.3, after: {event: lift, arm: PSM1}}"


def faulty_trial(tmp_path: Path, name: str, plan: str, seed: int = 3):
    faults = tmp_path / f"{name}.yaml"
    faults.write_text(plan)
    spec = TrialSpec(
        "unilateral", "optimized", seed, tmp_path / f"{name}.jsonl", faults, tree=short_task(tmp_path)
    )
    return run_trial(spec)


@pytest.mark.parametrize(
    ("name", "plan", "step"),
    [
        ("misses", "world: {miss_probability: 1.0}\n", "grasp"),  # every grasp would have held, and misses
        (
            "slips",
            "world: {slips: [" + CARRYING + ", {time: 0.6, after: {event: grasp, arm: PSM1, nth: 2}}]}\n",
            "carry",
        ),  # both carries lose the block: the first off its peg, the second (the regrasp's) off the board
        (
            "bursts",
            "camera: {burst_probability: 1.0}\n",
            "sense",
        ),  # every capture is noise: nothing is ever seen
    ],
)
def test_why_names_the_step_the_simulator_confirms(tmp_path, name, plan, step):
    record = faulty_trial(tmp_path, name, plan)
    assert record.outcome == "failure" and not record.complete
    assert record.why, "a failed trial is checked"
    for check in record.why:
        assert check["agrees"], check
    assert step in {check["named_step"] for check in record.why}
    assert step in {check["truth"]["step"] for check in record.why}
    # the same verdict from the command a person would run
    why = subprocess.run(
        [sys.executable, "-m", "pegbt", "log", "why", record.log],
        capture_output=True,
        text=True,
        cwd=REPO,
        timeout=60,
    )
    assert why.returncode == 0
    for check in record.why:
        assert check["named"].rpartition(": ")[2] in why.stdout


def test_a_recovered_fault_counts_as_recovered(tmp_path):
    record = faulty_trial(tmp_path, "one-miss", "world: {miss_attempts: [0]}\n")
    assert record.complete and record.outcome == "success" and not record.why
    assert [(fault["kind"], fault["transfer"], fault["recovered"]) for fault in record.faults] == [
        ("grasp miss", 1, True)
    ]


def test_a_stray_block_is_fetched_and_the_empty_peg_named(tmp_path):
    """The campaign's commonest disagreement: a transfer given up after a slip leaves its block on the board,
    and the later transfer from its (empty) goal peg fetches it. The simulator judges that later transfer
    failed (nothing was on its pick peg); `why` must say so (sense), not stay silent because the stray block
    got home."""
    tree = tmp_path / "stray.yaml"
    with_shared_trees(tree.parent)
    tree.write_text(
        "include: [shared/one_transfer.yaml, shared/sense.yaml]\n"
        "blackboard: {/policy/skip_failed_blocks: true, /PSM1/may_carry: true, /PSM2/may_carry: true}\n"
        "tree:\n  sequence:\n"
        "    - subtree: {use: clear_view}\n"
        "    - subtree: {use: transfer_block, args: {arm: PSM1, pick: 1, place: 7, regrasps: 0}}\n"
        "    - subtree: {use: transfer_block, args: {arm: PSM1, pick: 7, place: 1}}\n"
        "    - subtree: {use: clear_view, name: look at the result}\n"
        "    - check_placed: {name: block home, pegs: [1]}\n"
    )
    faults = tmp_path / "slip.yaml"
    faults.write_text(
        f"world: {{slips: [{CARRYING}]}}\n"
    )  # seed 3: the block falls on the board, off every peg
    record = run_trial(TrialSpec("unilateral", "optimized", 3, tmp_path / "stray.jsonl", faults, tree=tree))
    assert record.outcome == "success", "the stray block was fetched and placed on peg 1"
    assert [(t["succeeded"], t["cause"]) for t in record.transfers] == [(False, "carry"), (False, "sense")]
    assert [(check["transfer"], check["named_step"], check["agrees"]) for check in record.why] == [
        (1, "carry", True),
        (2, "sense", True),
    ]
    assert "no block seen on peg 7" in record.why[1]["named"]


def test_a_burst_lasting_two_captures_is_waited_out(tmp_path):
    """A depth-noise burst that spoils a capture and its immediate retake: sense pauses, looks again and the
    trial completes (six captures at once, 40 ms apart, would all fall in the burst); every burst capture is
    counted, and counted as recovered."""
    record = faulty_trial(tmp_path, "long-burst", "camera: {bursts: [{start: 0.0, duration: 1.85}]}\n")
    assert record.complete and record.outcome == "success" and not record.why
    bursts = [fault for fault in record.faults if fault["kind"] == "depth noise burst"]
    assert len(bursts) >= 2 and all(fault["recovered"] for fault in bursts)


def log_why(log: str) -> str:
    """What `pegbt log why LOG` prints."""
    why = subprocess.run(
        [sys.executable, "-m", "pegbt", "log", "why", log],
        capture_output=True,
        text=True,
        cwd=REPO,
        timeout=60,
    )
    assert why.returncode == 0, why.stderr
    return why.stdout


def test_a_block_that_slipped_and_was_missed_when_picked_again_is_named_by_the_slip(tmp_path):
    """The slip began the chain; the re-grasp that missed only followed it. The simulator ends the transfer
    on the miss and confirms the slip just before the leaf that reported it."""
    record = faulty_trial(tmp_path, "slip-then-miss", f"world: {{slips: [{CARRYING}], miss_attempts: [1]}}\n")
    [check] = [check for check in record.why if check["transfer"] == 1]
    assert (check["named_step"], check["truth"]["step"], check["confirmed"], check["agrees"]) == (
        "carry",
        "grasp",
        True,
        True,
    )
    assert re.search(  # the jaw closing on nothing, at most its squeeze (-15°)
        r"lift carry and lower: the block slipped from PSM1's jaw \(jaw at -1[0-5]°\) during lift carry and lower$",
        check["named"],
    )
    given_up = log_why(record.log).split("given up (the tree went on without it):")[1]
    assert (
        "first cause: pick and carry/lift PSM1 7/lift and carry/lift carry and lower (transfer) failed at t="
        in given_up
    )
    assert (
        "blackboard it read: /PSM1/block=BlockEstimate(" in given_up
        and "/PSM1/grasp=Grasp(arm='PSM1'" in given_up
    )
    assert "then: pick and carry/pick PSM1 1/pick from peg 1/close and check at t=" in given_up


def test_a_giver_whose_receiver_never_came_is_named_by_the_wait_and_the_simulator_confirms_it(tmp_path):
    """A giver alone: it holds the block out, waits for a receiver that said it was ready but never comes, and
    lets go. `why` names the wait it gave up (what it halted says so); the simulator saw the block never pass
    to the receiver."""
    tree = tmp_path / "giver.yaml"
    with_shared_trees(tree.parent)
    tree.write_text(
        "include: [shared/handover.yaml, shared/sense.yaml]\n"
        "tree:\n  sequence:\n"
        "    - subtree: {use: clear_view}\n"
        "    - ready_for: {name: a receiver said it is ready, n: 1}\n"
        "    - force_success: {name: g, child: {subtree: {use: give, args: {giver: PSM2, receiver: PSM1, n: 1, pick: 1, place: 7,"
        " regrasps: 0, patience: 2.0}}}}\n"
    )
    record = run_trial(TrialSpec("handover", "optimized", 3, tmp_path / "giver.jsonl", None, tree=tree))
    [check] = record.why
    assert (check["named_step"], check["truth"]["step"], check["agrees"]) == ("handover", "handover", True)
    state = "/handover/state_1: handover 1: giver arrived, receiver ready"
    assert check["named"].endswith(f"the receiver takes it: not taken after 2 s ({state})")
    why = log_why(record.log)
    assert "the receiver takes it (await_taker) failed at t=" in why
    assert "blackboard it read: /handover/state_1=Handover(1, giver=arrived, receiver=ready)" in why
