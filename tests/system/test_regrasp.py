"""A pick again after a missed grasp tries another of the block's grasp candidates, not the one that missed."""

from __future__ import annotations

from trial_helpers import short_task

from pegbt.evaluation.trial import TrialSpec, run_trial
from pegbt.perception.grasp import GraspSelector


def test_the_pick_after_a_miss_chooses_another_candidate(tmp_path, monkeypatch):
    chosen = []
    pick = GraspSelector.pick

    def recording(self, block, avoid=(), acceptable=None):
        grasp = pick(self, block, avoid, acceptable)
        chosen.append(grasp.candidate)
        return grasp

    monkeypatch.setattr(GraspSelector, "pick", recording)
    faults = tmp_path / "miss.yaml"
    faults.write_text("world: {miss_attempts: [0]}\n")
    record = run_trial(
        TrialSpec("unilateral", "optimized", 3, tmp_path / "miss.jsonl", faults, tree=short_task(tmp_path))
    )
    assert record.complete and [fault["recovered"] for fault in record.faults] == [True]
    assert len(chosen) == 2 and chosen[0] != chosen[1], chosen
