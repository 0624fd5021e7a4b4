"""The simulator's ground truth on hand-written event logs: what set a failed transfer back, in the words the
executive's leaves use (`pegbt.evaluation.truth`)."""

from __future__ import annotations

from pegbt.evaluation.truth import confirms, failure_cause, final_check_cause, setbacks

BURST = {
    "kind": "fault",
    "arm": None,
    "block": None,
    "peg": None,
    "detail": "depth noise burst: sigma 3.0 mm, 5% outliers",
}


def event(
    time: float,
    kind: str,
    arm: str | None = None,
    block: int | None = None,
    peg: int | None = None,
    detail: str = "",
) -> dict:
    return {"time": time, "kind": kind, "arm": arm, "block": block, "peg": peg, "detail": detail}


def handover(
    index: int = 4, pick: int = 2, place: int = 9, started: float = 20.0, ended: float | None = 40.0
) -> dict:
    return {
        "index": index,
        "arms": "PSM2→PSM1",
        "pick": pick,
        "place": place,
        "succeeded": False,
        "started": started,
        "ended": ended,
    }


GIVER_HOLDS_IT_OUT = [
    event(22.0, "grasp", "PSM2", 2, 2, "edge 1"),
    event(22.5, "lift", "PSM2", 2, 2, "cleared peg 2"),
]


def test_a_block_the_receiver_never_took_from_the_giver_is_a_handover_failure_not_the_noise_burst():
    """The giver held the block out; the receiver closed where no block was (the simulator logs no attempt), and
    a burst spoiled a capture meanwhile. Perception had found the block: the handover failed."""
    entries = [*GIVER_HOLDS_IT_OUT, {**BURST, "time": 28.5}]
    cause = failure_cause(handover(), entries)
    assert (cause.step, cause.event, cause.time) == ("handover", "PSM1 never gripped block 2 from PSM2", None)
    assert confirms("handover", 39.0, setbacks(handover(), entries))
    taken = [*GIVER_HOLDS_IT_OUT, event(24.0, "grasp", "PSM1", 2, None, "edge 0, handover from PSM2")]
    assert not any(c.step == "handover" for c in setbacks(handover(), taken))


def test_a_block_the_giver_let_go_of_that_fell_never_passed_unless_the_receiver_had_lost_it():
    dropped = [
        *GIVER_HOLDS_IT_OUT,
        event(31.0, "release", "PSM2", 2),
        event(31.0, "drop", "PSM2", 2, None, "onto the board"),
    ]
    assert failure_cause(handover(), dropped).step == "handover"
    on_a_peg = [*GIVER_HOLDS_IT_OUT, event(31.0, "release", "PSM2", 2), event(31.0, "place", "PSM2", 2, 6)]
    assert (failure_cause(handover(), on_a_peg).step, failure_cause(handover(), on_a_peg).time) == (
        "handover",
        31.0,
    )
    slipped = [
        *GIVER_HOLDS_IT_OUT,
        event(24.0, "grasp", "PSM1", 2, None, "edge 0, handover from PSM2"),
        event(24.1, "slip", "PSM1", 2, None, "injected fault"),
        event(24.2, "release", "PSM2", 2),
        event(24.2, "place", "PSM2", 2, 6),
    ]
    assert [(c.step, c.time) for c in setbacks(handover(), slipped)] == [
        ("carry", 24.1)
    ]  # the fall follows from the slip


def test_a_block_the_giver_set_back_on_its_start_peg_was_no_handover_lost():
    """The giver's block slipped onto the board; it set it back on its start peg and picked it again from
    there (`trees/shared/set_back.yaml`): the slip set the handover back, the set-back did not."""
    set_back = [
        *GIVER_HOLDS_IT_OUT,
        event(23.0, "slip", "PSM2", 2, None, "injected fault"),
        event(23.0, "drop", "PSM2", 2, None, "onto the board off the top of peg 6"),
        event(26.0, "grasp", "PSM2", 2, None, "edge 2"),
        event(27.4, "release", "PSM2", 2, 2),
        event(27.4, "place", "PSM2", 2, 2),
        event(30.3, "grasp", "PSM2", 2, 2, "edge 0"),
        event(30.8, "lift", "PSM2", 2, 2, "cleared peg 2"),
    ]
    assert [(c.step, c.time) for c in setbacks(handover(), set_back)] == [
        ("carry", 23.0),
        ("handover", None),  # the receiver never gripped it
    ]
    taken = [*set_back, event(31.9, "grasp", "PSM1", 2, None, "edge 2, handover from PSM2")]
    assert [(c.step, c.time) for c in setbacks(handover(), taken)] == [("carry", 23.0)]


def test_a_receivers_miss_near_a_block_no_running_transfer_works_on_is_its_transfers():
    """The receiver of handover 12 closes three times near block 5, which transfer 11 had placed: a grasp miss
    of transfer 12. A miss on the block another transfer is working on then belongs to that one."""
    twelve = handover(12, pick=10, place=4, started=139.0, ended=154.7)
    eleven = {**handover(11, pick=11, place=5, started=120.0, ended=145.8), "succeeded": True}
    entries = [
        event(125.0, "grasp", "PSM1", 5, 11, "edge 0"),
        event(141.1, "grasp", "PSM1", 4, 10, "edge 2"),
        event(145.75, "place", "PSM2", 5, 5),
        *(event(t, "grasp_miss", "PSM2", 5, 5, "jaws miss it by 10.2 mm") for t in (147.9, 150.9, 153.8)),
    ]
    seen = setbacks(twelve, entries, [eleven, twelve])
    assert [(c.step, c.time) for c in seen if c.step == "grasp"] == [
        ("grasp", 147.9),
        ("grasp", 150.9),
        ("grasp", 153.8),
    ]
    assert confirms("grasp", 148.0, seen)
    early_miss = [
        *entries,
        event(143.0, "grasp_miss", "PSM2", 5, None, "jaw below the block"),
    ]  # transfer 11 still runs
    assert not confirms("grasp", 143.1, setbacks(twelve, early_miss, [eleven, twelve]))


def test_a_transfer_that_never_touched_its_block_is_sense_with_evidence_else_reach():
    """Nobody went for the block on peg 3: an empty peg or one holding two blocks is for perception to see, a block
    alone there that nothing happened to was never reached."""
    transfer = {
        "index": 3,
        "arms": "PSM2→PSM1",
        "pick": 3,
        "place": 8,
        "succeeded": False,
        "started": 40.0,
        "ended": 70.0,
    }
    cause = failure_cause(transfer, [])
    assert (cause.step, cause.event) == (
        "reach",
        "no arm went for block 3, alone on peg 3 while the transfer ran",
    )
    two = [event(30.0, "lift", "PSM1", 4, 4), event(31.0, "place", "PSM1", 4, 3)]
    assert (failure_cause(transfer, two).step, failure_cause(transfer, two).event) == (
        "sense",
        "peg 3 held blocks 3 and 4 when the transfer began",
    )
    burst = [{**BURST, "time": 50.0}]
    assert failure_cause(transfer, burst).step == "sense"
    assert confirms("reach", 55.0, setbacks(transfer, burst))  # no arm went for it, burst or not
    empty = [event(30.0, "lift", "PSM1", 3, 3)]
    assert failure_cause(transfer, empty).event == "no block was on peg 3 when the transfer began"


def test_a_run_that_failed_at_a_leaf_checking_no_pegs_is_sense_only_after_a_burst():
    """A look that gave up in a noise burst is confirmed; a motion the executive refused never reached the
    simulator, which saw nothing go wrong."""
    assert final_check_cause([], [{**BURST, "time": 2.3}], 2.5).step == "sense"
    assert (
        final_check_cause([], [{**BURST, "time": 2.3}], 60.0).step,
        final_check_cause([], [], 60.0).event,
    ) == ("none", "the simulator saw nothing go wrong before t=60.00 s")
