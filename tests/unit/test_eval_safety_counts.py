"""A campaign's safety counts from the simulator's log: a FAULT counts once however many state changes follow
it, and only clips count as clips."""

from __future__ import annotations

from pegbt.evaluation.truth import count_safety


def test_a_fault_counts_once_however_many_state_changes_follow_it_and_only_clips_count_as_clips():
    entries = [
        {"kind": "arm_state", "arm": "PSM1", "state": "ENABLED"},
        {"kind": "safety", "arm": "PSM1", "event": "not_ready", "command": "servo_jp"},
        {"kind": "safety", "arm": "PSM1", "event": "clip", "command": "servo_jp"},
        {"kind": "arm_state", "arm": "PSM1", "state": "FAULT"},
        {"kind": "arm_state", "arm": "PSM2", "state": "ENABLED"},
        {"kind": "arm_state", "arm": "PSM1", "state": "FAULT"},  # unhomed while in FAULT: the same fault
        {"kind": "arm_state", "arm": "PSM1", "state": "ENABLED"},
        {"kind": "arm_state", "arm": "PSM1", "state": "FAULT"},
    ]
    assert count_safety(entries) == (1, 2)
