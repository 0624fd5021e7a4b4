"""`grasp_capture` in the phase simulator: bilateral's PSM2, under pegbt's protocol, misses its grasp on peg 2,
the jaws closing further off the wall's centre than the peg lets the block slide and its wrist's cable play
takes; with the wrist yielding the rest, the same transfer gets past its grasp. (Under the paper's protocol
its arm now comes from a place at roll 0, `paperplacing`, and grasps it.)"""

from __future__ import annotations

from pegbt.sim.world_effects import WorldEffects
from pegbt.sim2real.outcomes.phasesim import simulate_transfer


def test_bilateral_psm2_s_peg_stopped_grasp_succeeds_with_the_wrist_s_capture_width():
    def transfer(effects: WorldEffects):  # PSM2's 2 -> 6 of layout 0, one attempt
        return simulate_transfer(
            effects, "bilateral", "uncalibrated", 0, index=1, attempts=1, registered=False
        )

    rigid = transfer(WorldEffects())
    assert not rigid.succeeded and rigid.phase == "grasp"
    captured = transfer(WorldEffects.of({"grasp_capture": {"width": 0.003}}))
    assert captured.phase != "grasp"  # grasped (and, looked at before the lowering, placed)
