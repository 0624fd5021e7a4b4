"""`grasp_capture` in the phase simulator: the uncalibrated handover's giver (PSM2) misses its grasp on the
start peg, the jaws closing further off the wall's centre than the peg lets the block slide; with the
wrist yielding the rest, the same transfer gets past its grasp."""

from __future__ import annotations

from pegbt.sim.world_effects import WorldEffects
from pegbt.sim2real.outcomes.phasesim import simulate_transfer


def test_the_handover_giver_s_peg_stopped_grasp_succeeds_with_the_wrist_s_capture_width():
    rigid = simulate_transfer(WorldEffects(), "handover", "uncalibrated", 0)
    assert not rigid.succeeded and rigid.phase == "grasp"
    captured = simulate_transfer(
        WorldEffects.of({"grasp_capture": {"width": 0.003}}), "handover", "uncalibrated", 0
    )
    assert captured.phase not in (None, "grasp")  # grasped, handed over, then lost further on
