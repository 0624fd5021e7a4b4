"""The runner's wake-up hints: running leaves that say when they next need a tick let the clock run on."""

from __future__ import annotations

from executive_helpers import build_text

from pegbt.clock import ManualClock
from pegbt.executive.runner import run


def ticks_of(tmp_path, text: str, period: float = 0.1) -> tuple[int, float]:
    clock = ManualClock()
    result = run(build_text(tmp_path, text, clock), period=period)
    assert result.outcome == "success"
    return result.ticks, clock.now()


def test_a_leaf_with_a_hint_is_not_ticked_before_it(tmp_path):
    ticks, now = ticks_of(tmp_path, "tree: {wait: {seconds: 1.0}}")
    assert ticks == 2 and abs(now - 1.0) < 1e-9  # the start and the end, not eleven ticks


def test_a_running_leaf_without_a_hint_is_ticked_every_period(tmp_path):
    text = "tree:\n  parallel:\n    - wait: {seconds: 1.0}\n    - scripted: {outcomes: [running, running, running, running, success]}\n"
    ticks, _ = ticks_of(tmp_path, text)
    assert ticks == 6  # five ticks for the scripted leaf, then the wait's end at 1.0 s


def test_a_blackboard_write_wakes_a_waiting_branch_at_the_next_period(tmp_path):
    text = (
        "tree:\n  parallel:\n    children:\n"
        "      - wait_blackboard: {name: waiter, key: /go, op: '==', value: 1}\n"
        "      - sequence: [{wait: {seconds: 0.5}}, {set_blackboard: {key: /go, value: 1}}]\n"
    )
    ticks, now = ticks_of(tmp_path, text)
    assert ticks == 3 and abs(now - 0.6) < 1e-9  # start, the write at 0.5 s, the waiter going on at 0.6 s
