"""The handover protocol: its named record (pure), the leaves that set and test it, and what the tick log and
`pegbt log why` show of it when a handover fails."""

from __future__ import annotations

import json

from executive_helpers import build_text, node
from py_trees.common import Status

from pegbt.cli import main
from pegbt.clock import ManualClock
from pegbt.handover_protocol import CONDITIONS, Giver, Handover, Receiver, key


def test_a_record_says_each_sides_last_word_by_name():
    record = Handover(3).said(Receiver.READY).said(Giver.OFFERED).said(Giver.ARRIVED).said(Receiver.CLOSING)
    assert (record.giver, record.receiver) == ("arrived", "closing")
    assert str(record) == "handover 3: giver arrived, receiver closing"
    assert CONDITIONS["offered"](record) and not CONDITIONS["not closing"](record)
    withdrawn = record.said(Giver.WITHDRAWN).said(Receiver.READY)
    assert not CONDITIONS["offered"](withdrawn) and CONDITIONS["withdrawn"](withdrawn)
    assert CONDITIONS["not closing"](withdrawn) and CONDITIONS["ready"](withdrawn)
    assert Handover(3) == Handover(3) and key(3) == "/handover/state_3"


def test_a_giver_coming_with_the_block_lets_the_receiver_come_but_holds_nothing_out_yet():
    coming = Handover(2).said(Receiver.READY).said(Giver.COMING)
    assert CONDITIONS["offered"](coming) and CONDITIONS["offered or given up"](coming)
    assert not CONDITIONS["arrived"](coming) and not CONDITIONS["withdrawn"](coming)
    assert CONDITIONS["withdrawn"](coming.said(Giver.WITHDRAWN))


def test_a_giver_that_gave_up_is_neither_offering_nor_waited_for():
    given_up = Handover(1).said(Giver.OFFERED).said(Giver.GIVEN_UP)
    assert not CONDITIONS["offered"](given_up)
    assert CONDITIONS["offered or given up"](given_up) and not CONDITIONS["not given up"](given_up)
    assert not CONDITIONS["ready"](Handover(1)) and CONDITIONS["not refused"](Handover(1))


PIPELINE = """
tree:
  parallel:
    name: one handover
    children:
      - sequence:
          name: giver
          children:
            - await_ready: {name: until ready, n: 1, patience: 5.0}
            - offer: {name: offer, n: 1}
            - wait: {name: carry, seconds: 0.3}
            - hold_out: {name: arrived, n: 1}
            - parallel:
                name: until taken
                policy: one
                children:
                  - await_taker: {name: the receiver takes it, n: 1, patience: PATIENCE}
                  - unless_refused: {name: unless refused, n: 1}
            - hand_over: {name: released, n: 1}
      - sequence:
          name: receiver
          children:
            - wait: {name: busy with the last one, seconds: 0.2}
            - ready_for: {name: ready, n: 1}
            - await_offer: {name: the giver offers it, n: 1, patience: 5.0}
            - not_given_up: {name: not given up, n: 1}
            - await_arrival: {name: it arrives, n: 1, patience: 5.0}
            - RECEIVER_CLOSES
"""


def _tree(tmp_path, closes: str, patience: float = 5.0):
    clock = ManualClock()
    text = PIPELINE.replace("PATIENCE", str(patience)).replace("- RECEIVER_CLOSES", closes)
    return build_text(tmp_path, text, clock), clock


def _run(built, clock, ticks: int = 40) -> Status:
    """Tick every 0.1 s until the tree finishes; its result."""
    for _ in range(ticks):
        built.root.tick_once()
        if built.root.status != Status.RUNNING:
            return built.root.status
        clock.advance(0.1)
    return built.root.status


def test_giver_and_receiver_meet_only_through_the_record(tmp_path):
    built, clock = _tree(
        tmp_path,
        "- close_on: {name: closing, n: 1}\n            - take: {name: taken, n: 1}\n"
        "            - await_release: {name: let go, n: 1, patience: 5.0}",
    )
    assert _run(built, clock) == Status.SUCCESS
    assert (
        node(built, "released").feedback_message
        == "/handover/state_1: handover 1: giver released, receiver taken"
    )
    assert node(built, "until ready").feedback_message.startswith("ready (")


CALLED_OVER = """
tree:
  parallel:
    name: one handover
    children:
      - sequence:
          name: giver
          children:
            - call_over: {name: come, n: 1}
            - wait: {name: picking, seconds: 0.5}
            - offer: {name: offer, n: 1}
      - sequence:
          name: receiver
          children:
            - ready_for: {name: ready, n: 1}
            - await_offer: {name: called over, n: 1, patience: 5.0}
"""


def test_a_receiver_called_over_sets_off_while_the_giver_still_picks(tmp_path):
    clock = ManualClock()
    built = build_text(tmp_path, CALLED_OVER, clock)
    came_at = None
    while built.root.status != Status.SUCCESS and clock.now() < 2.0:
        built.root.tick_once()
        if came_at is None and node(built, "called over").status == Status.SUCCESS:
            came_at = clock.now()
            assert node(built, "called over").feedback_message == (
                "offered or given up (/handover/state_1: handover 1: giver coming, receiver ready)"
            )
        clock.advance(0.1)
    assert came_at is not None and came_at < 0.5  # before the giver offers the block it picked
    assert built.root.status == Status.SUCCESS


def test_a_receiver_that_refuses_ends_the_givers_wait_at_once(tmp_path):
    built, clock = _tree(tmp_path, "- refuse: {name: refuse it, n: 1}")
    assert _run(built, clock) == Status.FAILURE
    assert node(built, "unless refused").status == Status.FAILURE
    assert node(built, "unless refused").feedback_message == (
        "no longer not refused (/handover/state_1: handover 1: giver arrived, receiver refused)"
    )


def test_a_wait_out_of_patience_fails_on_the_executives_clock(tmp_path):
    built, clock = _tree(tmp_path, "- wait: {name: never closes, seconds: 100.0}", patience=1.0)
    times = []
    for _ in range(40):
        built.root.tick_once()
        times.append((clock.now(), node(built, "the receiver takes it").status))
        if built.root.status != Status.RUNNING:
            break
        clock.advance(0.1)
    arrived_at = next(t for t, status in times if status == Status.RUNNING)
    failed_at = next(t for t, status in times if status == Status.FAILURE)
    assert 1.0 < failed_at - arrived_at <= 1.1 + 1e-9  # as `timeout` did: after, never at, the deadline
    assert node(built, "the receiver takes it").feedback_message == (
        "not taken after 1 s (/handover/state_1: handover 1: giver arrived, receiver ready)"
    )


def test_log_why_of_a_failed_handover_names_the_protocol_state(tmp_path, capsys):
    tree = tmp_path / "handover.yaml"
    tree.write_text(
        PIPELINE.replace("PATIENCE", "1.0").replace(
            "- RECEIVER_CLOSES",
            "- close_on: {name: closing, n: 1}\n            - wait: {name: jaw stuck, seconds: 9}",
        )
    )
    log = tmp_path / "run.jsonl"
    assert main(["run", str(tree), "--clock", "manual", "--period", "0.1", "--log", str(log), "--quiet"]) == 1
    records = [json.loads(line) for line in log.read_text().splitlines()]
    written = [
        record["bb"][key(1)] for record in records if "bb" in record and key(1) in record.get("bb", {})
    ]
    assert [word["repr"] for word in written] == [
        "Handover(1, giver=none, receiver=ready)",
        "Handover(1, giver=offered, receiver=ready)",
        "Handover(1, giver=arrived, receiver=closing)",  # the receiver closes in the tick the block arrives
    ]
    capsys.readouterr()
    assert main(["log", "why", str(log)]) == 0
    why = capsys.readouterr().out
    assert "the receiver takes it (await_taker) failed at t=" in why
    assert "not taken after 1 s (/handover/state_1: handover 1: giver arrived, receiver closing)" in why
    assert "blackboard it reads: /handover/state_1=Handover(1, giver=arrived, receiver=closing)" in why


WORDS = """
tree:
  sequence:
    name: words
    children:
      - ready_for: {name: ready, n: 2}
      - receiver_waits: {name: still waits, n: 2}
      - offer: {name: offer, n: 2}
      - is_offered: {name: offered, n: 2}
      - hold_out: {name: hold out, n: 2}
      - is_held_out: {name: held out, n: 2}
      - close_on: {name: close, n: 2}
      - back_off: {name: back off, n: 2}
      - await_closed: {name: jaw not closing, n: 2, patience: 1.0}
      - withdraw: {name: withdraw, n: 2}
      - is_withdrawn: {name: withdrawn, n: 2}
      - take: {name: take, n: 2}
      - is_taken: {name: taken, n: 2}
      - give_up: {name: give up, n: 2}
      - LAST
"""


def _words(tmp_path, last: str):
    clock = ManualClock()
    return build_text(tmp_path, WORDS.replace("- LAST", last), clock), clock


def test_each_word_is_written_by_name_and_each_check_reads_it(tmp_path):
    built, clock = _words(tmp_path, "- is_withdrawn: {name: given up counts as withdrawn, n: 2}")
    assert _run(built, clock) == Status.SUCCESS
    assert node(built, "back off").feedback_message.endswith("giver arrived, receiver ready")
    assert node(built, "withdrawn").feedback_message == (
        "withdrawn (/handover/state_2: handover 2: giver withdrawn, receiver ready)"
    )
    assert node(built, "given up counts as withdrawn").feedback_message.endswith(
        "giver given up, receiver taken)"
    )


def test_a_check_that_does_not_hold_fails_and_says_why(tmp_path):
    built, clock = _words(tmp_path, "- not_given_up: {name: still giving, n: 2}")
    assert _run(built, clock) == Status.FAILURE
    assert node(built, "still giving").feedback_message == (
        "not: not given up (/handover/state_2: handover 2: giver given up, receiver taken)"
    )
    for check, word in (("is_taken", "taken"), ("is_offered", "offered"), ("is_held_out", "arrived")):
        built = build_text(
            tmp_path,
            "tree:\n  sequence:\n    name: s\n    children:\n      - ready_for: {name: ready, n: 4}\n"
            f"      - {check}: {{name: {check}, n: 4}}\n",
            ManualClock(),
        )
        built.root.tick_once()
        assert built.root.status == Status.FAILURE
        assert node(built, check).feedback_message == (
            f"not: {word} (/handover/state_4: handover 4: giver not offered yet, receiver ready)"
        )


def test_a_receiver_that_refused_is_no_longer_waiting(tmp_path):
    built = build_text(
        tmp_path,
        "tree:\n  sequence:\n    name: s\n    children:\n      - refuse: {name: refuse, n: 5}\n"
        "      - receiver_waits: {name: waits, n: 5}\n",
        ManualClock(),
    )
    built.root.tick_once()
    assert built.root.status == Status.FAILURE
    assert node(built, "waits").feedback_message.startswith("not: not refused (")
