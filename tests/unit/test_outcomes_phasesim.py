"""The phase simulator: one transfer's phases on the world with the dvrk-real arm, as the executive would
command it, and the world effects changing what happens in them."""

from __future__ import annotations

from pegbt.sim.world_effects import WorldEffects
from pegbt.sim2real.outcomes.phasesim import simulate_transfer

SEEDS = range(4)


def test_uncalibrated_lifts_fail_on_rigid_pegs_and_pass_on_bending_ones():
    rigid = [simulate_transfer(WorldEffects(), "unilateral", "uncalibrated", s) for s in SEEDS]
    bending = WorldEffects.of({"peg_compliance": {"deflection": 0.003}})
    bent = [simulate_transfer(bending, "unilateral", "uncalibrated", s) for s in SEEDS]
    assert any(r.phase == "lift" and not r.succeeded for r in rigid)
    assert sum(r.succeeded for r in bent) > sum(r.succeeded for r in rigid)
    assert all(r.phase != "lift" for r in bent if not r.succeeded)


def test_a_calibrated_transfer_is_placed_and_a_handover_passes_the_block():
    for variant in ("unilateral", "handover"):
        result = simulate_transfer(WorldEffects(), variant, "calibrated", 1)
        assert result.succeeded and result.seconds > 1.0, variant
