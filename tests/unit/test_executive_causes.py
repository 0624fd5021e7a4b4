"""`pegbt log why`'s failure chains on small hand-written tick logs: the first cause of a failure the tree gave
up on, what reached it (every child failure of an activation, repeats the log kept no change for, failures
absorbed on the way left out) and what it shows a person (blackboard values, the wait a timeout halted)."""

from __future__ import annotations

import json
from pathlib import Path

from pegbt.evaluation.why import named_step
from pegbt.executive.analysis import why
from pegbt.executive.causes import Timeline, failure_chains, fallbacks, recoveries
from pegbt.executive.logfile import TickLog, read_tick_log
from pegbt.executive.ticklog import FORMAT, FORMAT_VERSION

Change = tuple[str, str, str, str]  # node name (the last part of its path), before, after, feedback


def tick_log(
    tmp_path: Path,
    nodes: list[tuple[str, str]],
    ticks: list[tuple[float, list[Change]]],
    outcome: str = "success",
    reads: dict[str, list[str]] | None = None,
    blackboard: dict[str, object] | None = None,
) -> TickLog:
    """A tick log of the tree `nodes` ((path, type), parents first) and one tick per entry of `ticks` (t, changes),
    ticks numbered from 1; written as the runner writes it and read back."""
    reads = reads or {}
    ids = {path: index for index, (path, _) in enumerate(nodes)}
    by_name = {path.rpartition("/")[2]: index for path, index in ids.items()}
    table = [
        {
            "id": ids[path],
            "parent": ids.get(path.rpartition("/")[0]),
            "path": path,
            "name": path.rpartition("/")[2],
            "type": kind,
            "class": kind,
            "source": f"tree.yaml:{ids[path] + 1}:1",
            "params": {},
            "reads": reads.get(path.rpartition("/")[2], []),
            "writes": [],
            "subtree": None,
        }
        for path, kind in nodes
    ]
    records = [
        {
            "type": "header",
            "format": FORMAT,
            "format_version": FORMAT_VERSION,
            "tree": "tree.yaml",
            "nodes": table,
            "blackboard": blackboard or {},
        }
    ]
    records += [
        {
            "type": "tick",
            "n": n,
            "t": t,
            "changes": [
                [by_name[name], before, after, feedback] for name, before, after, feedback in changes
            ],
        }
        for n, (t, changes) in enumerate(ticks, start=1)
    ]
    records.append({"type": "end", "n": len(ticks), "t": ticks[-1][0], "outcome": outcome})
    path = tmp_path / "run.jsonl"
    path.write_text("".join(json.dumps(record) + "\n" for record in records))
    return read_tick_log(path)


# A recover node whose main picks and lifts; the tree gives the block up when the recoveries run out.
PICK_AND_LIFT = [
    ("/task", "selector"),
    ("/task/recovering", "recover"),
    ("/task/recovering/pick and lift", "sequence"),
    ("/task/recovering/pick and lift/choose", "select_grasp"),
    ("/task/recovering/pick and lift/close", "grasp"),
    ("/task/recovering/pick and lift/lift", "transfer"),
    ("/task/recovering/look again", "wait"),
    ("/task/give up", "log"),
]
STARTED = [
    ("choose", "INVALID", "SUCCESS", "chose candidate 2"),
    ("close", "INVALID", "RUNNING", ""),
    ("pick and lift", "INVALID", "RUNNING", ""),
    ("recovering", "INVALID", "RUNNING", ""),
    ("task", "INVALID", "RUNNING", ""),
]
GAVE_UP = [
    ("recovering", "RUNNING", "FAILURE", "main failed after 2 recover(ies); giving up"),
    ("give up", "INVALID", "SUCCESS", "gave up on the block"),
    ("task", "RUNNING", "SUCCESS", ""),
]


def test_a_block_that_slipped_then_could_not_be_picked_again_is_named_by_its_slip(tmp_path):
    """The re-grasps after a slip fail on nothing; the chain's first cause is the slip, shown with the blackboard
    values it read, and the failed re-grasps follow it."""
    log = tick_log(
        tmp_path,
        PICK_AND_LIFT,
        [
            (0.0, STARTED),
            (0.2, [("close", "RUNNING", "SUCCESS", "holds a block"), ("lift", "INVALID", "RUNNING", "")]),
            (
                0.4,
                [
                    ("lift", "RUNNING", "FAILURE", "the block slipped from PSM1's jaw"),
                    ("pick and lift", "RUNNING", "FAILURE", ""),
                    ("look again", "INVALID", "RUNNING", ""),
                ],
            ),
            (
                0.6,
                [
                    ("look again", "RUNNING", "SUCCESS", ""),
                    ("lift", "FAILURE", "INVALID", ""),
                    ("close", "SUCCESS", "RUNNING", ""),
                    ("pick and lift", "FAILURE", "RUNNING", ""),
                ],
            ),
            (
                0.8,
                [
                    ("close", "RUNNING", "FAILURE", "PSM1's jaw closed on nothing"),
                    ("pick and lift", "RUNNING", "FAILURE", ""),
                    ("look again", "SUCCESS", "RUNNING", ""),
                ],
            ),
            (
                1.0,
                [
                    ("look again", "RUNNING", "SUCCESS", ""),
                    ("close", "FAILURE", "RUNNING", ""),
                    ("pick and lift", "FAILURE", "RUNNING", ""),
                ],
            ),
            (
                1.2,
                [
                    ("close", "RUNNING", "FAILURE", "PSM1's jaw closed on nothing"),
                    ("pick and lift", "RUNNING", "FAILURE", ""),
                    *GAVE_UP,
                ],
            ),
        ],
        reads={"lift": ["/PSM1/grasp"]},
        blackboard={"/PSM1/grasp": {"repr": "Grasp(candidate=2,\n   yaw=0.4)"}},
    )
    [chain] = failure_chains(log)
    assert chain.handled == "given up" and chain.by == "/task/recovering" and chain.t == 1.2
    assert [(step.name, step.t) for step in chain.steps] == [("lift", 0.4), ("close", 0.8), ("close", 1.2)]
    assert chain.first_cause.name == "lift" and chain.first_cause.reads == (
        ("/PSM1/grasp", {"repr": "Grasp(candidate=2,\n   yaw=0.4)"}),
    )
    text = why(log)
    assert "/task/recovering: gave up at t=1.200 s" in text
    assert (
        "first cause: pick and lift/lift (transfer) failed at t=0.400 s, tick 3: the block slipped from PSM1's jaw"
        in text
    )
    assert "blackboard it read: /PSM1/grasp=Grasp(candidate=2, yaw=0.4)" in text  # a repr on one line
    assert "then: pick and lift/close at t=0.800 s: PSM1's jaw closed on nothing" in text
    assert text.index("first cause:") < text.index("then: pick and lift/close at t=1.200 s")


def test_a_main_that_fails_again_within_a_tick_is_still_in_the_chain_and_each_recovery_is_listed(tmp_path):
    """After the first recovery the block is not seen: `choose` fails the tick main is retried, and again after
    the second recovery, which the log keeps no change for (its status stays FAILURE)."""
    log = tick_log(
        tmp_path,
        PICK_AND_LIFT,
        [
            (0.0, STARTED),
            (0.2, [("close", "RUNNING", "SUCCESS", "holds a block"), ("lift", "INVALID", "RUNNING", "")]),
            (
                0.4,
                [
                    ("lift", "RUNNING", "FAILURE", "the block slipped from PSM1's jaw"),
                    ("pick and lift", "RUNNING", "FAILURE", ""),
                    ("look again", "INVALID", "RUNNING", ""),
                ],
            ),
            (
                0.6,
                [
                    ("look again", "RUNNING", "SUCCESS", ""),
                    ("choose", "SUCCESS", "FAILURE", "no block seen on peg 1"),
                    ("lift", "FAILURE", "INVALID", ""),
                    ("close", "SUCCESS", "INVALID", ""),
                    ("look again", "SUCCESS", "RUNNING", ""),
                ],
            ),
            (0.8, [("look again", "RUNNING", "SUCCESS", ""), *GAVE_UP]),
        ],
    )
    [chain] = failure_chains(log)
    assert [(step.name, step.feedback) for step in chain.steps] == [
        ("lift", "the block slipped from PSM1's jaw"),
        ("choose", "no block seen on peg 1"),
    ]
    runs = recoveries(Timeline(log))
    assert [
        (log.nodes[run.origin.node]["name"], run.failed_t, run.tried.t, run.then, run.then_t) for run in runs
    ] == [("lift", 0.4, 0.6, "failed", 0.6), ("choose", 0.6, 0.8, "failed", 0.8)]
    assert (
        "main failed at t=0.600 s (choose: no block seen on peg 1); recovery success at t=0.800 s; "
        "main was retried and failed again at t=0.800 s: it did not help" in why(log)
    )


def test_an_alternative_that_failed_before_its_selector_started_is_the_first_cause(tmp_path):
    """A tick logs children before their parents: the carry failed in the tick its selector started, and was
    reset before the fallback failed too. Both failed; the carry first."""
    log = tick_log(
        tmp_path,
        [
            ("/run", "sequence"),
            ("/run/keep going", "force_success"),
            ("/run/keep going/carry or fetch", "selector"),
            ("/run/keep going/carry or fetch/carry", "carry_from_handover"),
            ("/run/keep going/carry or fetch/fetch", "park"),
        ],
        [
            (
                0.0,
                [
                    ("carry", "INVALID", "FAILURE", "the block slipped during carry to the goal peg"),
                    ("fetch", "INVALID", "RUNNING", ""),
                    ("carry or fetch", "INVALID", "RUNNING", ""),
                    ("keep going", "INVALID", "RUNNING", ""),
                    ("run", "INVALID", "RUNNING", ""),
                ],
            ),
            (0.1, [("carry", "FAILURE", "INVALID", "")]),
            (
                0.2,
                [
                    ("fetch", "RUNNING", "FAILURE", "trajectory start refused"),
                    ("carry or fetch", "RUNNING", "FAILURE", ""),
                    ("keep going", "RUNNING", "SUCCESS", ""),
                    ("run", "RUNNING", "SUCCESS", ""),
                ],
            ),
        ],
    )
    [chain] = failure_chains(log)
    assert [step.name for step in chain.steps] == ["carry", "fetch"] and chain.first_cause.name == "carry"
    assert named_step(chain.first_cause) == "carry"


def test_control_flow_is_passed_over_and_a_failure_absorbed_on_the_way_left_out(tmp_path):
    """A capture retried with success is no part of the chain; a check that steered the selector echoes, and
    the grasp behind it, whose retry went on running when it first failed and failed later, is the cause."""
    log = tick_log(
        tmp_path,
        [
            ("/run", "force_success"),
            ("/run/attempt", "sequence"),
            ("/run/attempt/look", "retry"),
            ("/run/attempt/look/capture", "capture"),
            ("/run/attempt/done or grasp", "selector"),
            ("/run/attempt/done or grasp/already done", "check_blackboard"),
            ("/run/attempt/done or grasp/grasp it", "retry"),
            ("/run/attempt/done or grasp/grasp it/close", "grasp"),
        ],
        [
            (
                0.0,
                [
                    ("capture", "INVALID", "FAILURE", "a poor capture"),
                    ("look", "INVALID", "RUNNING", ""),
                    ("attempt", "INVALID", "RUNNING", ""),
                    ("run", "INVALID", "RUNNING", ""),
                ],
            ),
            (
                0.1,
                [
                    ("capture", "FAILURE", "SUCCESS", "127312 points"),
                    ("look", "RUNNING", "SUCCESS", ""),
                    ("already done", "INVALID", "FAILURE", "'/done' comparison failed"),
                    ("close", "INVALID", "FAILURE", "closed on nothing"),
                    ("grasp it", "INVALID", "RUNNING", "attempt failed"),
                    ("done or grasp", "INVALID", "RUNNING", ""),
                ],
            ),
            (
                0.2,
                [
                    ("grasp it", "RUNNING", "FAILURE", "final failure"),
                    ("done or grasp", "RUNNING", "FAILURE", ""),
                    ("attempt", "RUNNING", "FAILURE", ""),
                    ("run", "RUNNING", "SUCCESS", ""),
                ],
            ),
        ],
    )
    [chain] = failure_chains(log)
    assert [step.name for step in chain.steps] == ["already done", "close"]
    assert chain.first_cause.name == "close" and named_step(chain.first_cause) == "grasp"


def test_a_timeout_shows_the_wait_it_halted_and_a_give_up_inside_another_is_told_once(tmp_path):
    log = tick_log(
        tmp_path,
        [
            ("/run", "sequence"),
            ("/run/give", "force_success"),
            ("/run/give/hold it out", "recover"),
            ("/run/give/hold it out/the receiver takes it", "timeout"),
            ("/run/give/hold it out/the receiver takes it/wait until taken", "wait_blackboard"),
            ("/run/give/hold it out/fetch it again", "park"),
        ],
        [
            (
                0.0,
                [
                    ("wait until taken", "INVALID", "RUNNING", "waiting for /handover/taken == 1 (now 0)"),
                    ("the receiver takes it", "INVALID", "RUNNING", "20 s left"),
                    ("hold it out", "INVALID", "RUNNING", ""),
                    ("give", "INVALID", "RUNNING", ""),
                    ("run", "INVALID", "RUNNING", ""),
                ],
            ),
            (
                20.0,
                [
                    ("the receiver takes it", "RUNNING", "FAILURE", "timed out after 20 s"),
                    ("wait until taken", "RUNNING", "INVALID", "waiting for /handover/taken == 1 (now 0)"),
                    ("hold it out", "RUNNING", "FAILURE", "main failed after 0 recover(ies); giving up"),
                    ("give", "RUNNING", "SUCCESS", ""),
                    ("run", "RUNNING", "SUCCESS", ""),
                ],
            ),
        ],
    )
    [chain] = failure_chains(log)
    assert chain.by == "/run/give"  # the recover node that gave up inside it is not told again
    assert chain.first_cause.halted == ("wait until taken: waiting for /handover/taken == 1 (now 0)",)
    assert named_step(chain.first_cause) == "handover"
    assert "it halted: wait until taken: waiting for /handover/taken == 1 (now 0)" in why(log)


def test_a_failure_a_fallback_made_up_for_is_listed_with_it(tmp_path):
    """The carry slipped and fetching the block from the board worked: no failure is left, but a person reading
    `why` sees the slip and what got over it (a check that steered a selector is not listed)."""
    log = tick_log(
        tmp_path,
        [
            ("/run", "sequence"),
            ("/run/registered or register", "selector"),
            ("/run/registered or register/registered", "check_blackboard"),
            ("/run/registered or register/register", "register_board"),
            ("/run/carry or fetch", "selector"),
            ("/run/carry or fetch/carry", "carry_from_handover"),
            ("/run/carry or fetch/fetch", "park"),
        ],
        [
            (
                0.0,
                [
                    ("registered", "INVALID", "FAILURE", "'/board_registered' comparison failed"),
                    ("register", "INVALID", "SUCCESS", ""),
                    ("registered or register", "INVALID", "SUCCESS", ""),
                    ("carry", "INVALID", "FAILURE", "the block slipped"),
                    ("fetch", "INVALID", "RUNNING", ""),
                    ("carry or fetch", "INVALID", "RUNNING", ""),
                    ("run", "INVALID", "RUNNING", ""),
                ],
            ),
            (
                0.5,
                [
                    ("fetch", "RUNNING", "SUCCESS", ""),
                    ("carry or fetch", "RUNNING", "SUCCESS", ""),
                    ("run", "RUNNING", "SUCCESS", ""),
                ],
            ),
        ],
    )
    assert failure_chains(log) == []
    found = fallbacks(Timeline(log))
    assert [
        (log.nodes[item.node]["name"], log.nodes[item.origin.node]["name"], item.succeeded.t)
        for item in found
    ] == [("carry or fetch", "carry", 0.5)]
    assert (
        "got over by another alternative or attempt:\n  /run/carry or fetch: carry failed at t=0.000 s (the block slipped); "
        "it went on and succeeded at t=0.500 s" in why(log)
    )
