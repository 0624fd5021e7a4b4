"""The phase simulator: one transfer's phases on the world with the dvrk-real arm, as the executive would
command it, and the world effects changing what happens in them."""

from __future__ import annotations

from pathlib import Path

import yaml

from pegbt.sim.world_effects import WorldEffects
from pegbt.sim2real.outcomes.phasesim import Replay, simulate_transfer, transfers

SEEDS = range(4)
ROOT = Path(__file__).resolve().parents[2]


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


def test_the_arm_replayed_across_worlds_gives_each_world_its_own_outcome():
    """One `Replay` shared by a transfer's worlds (the arm's motion simulated once) gives the outcomes,
    phases and seconds of simulating each world alone, including worlds where the block's fate differs."""
    worlds = [
        WorldEffects(),
        WorldEffects.of({"peg_compliance": {"deflection": 0.0012}}),
        WorldEffects.of({"peg_compliance": {"deflection": 0.0024}}),
        WorldEffects.of({"registration_offset": {"x": 0.002}}),
    ]
    for variant, condition, seed in (("unilateral", "uncalibrated", 3), ("bilateral", "uncalibrated", 2)):
        alone = [simulate_transfer(w, variant, condition, seed) for w in worlds]
        replay = Replay()
        shared = [simulate_transfer(w, variant, condition, seed, replay) for w in worlds]
        assert shared == alone, (variant, seed)
        assert len({(r.succeeded, r.phase) for r in alone}) > 1  # the block's fate differs across worlds


def test_the_transfers_simulated_are_the_trees_out_and_back():
    """Each variant's transfers, per arm in order, are those `trees/shared/orders.yaml` lists, the way back
    included (where a trial's returning lowerings fail)."""
    lists = yaml.safe_load((ROOT / "trees" / "shared" / "orders.yaml").read_text())["lists"]
    reference = [(row["pick"], row["place"]) for row in lists["reference"]]
    per_arm = {
        "unilateral": {"PSM1": reference},
        "handover": {"PSM2": reference[:6], "PSM1": reference[6:]},
        "bilateral": {
            arm: [(r["pick"], r["place"]) for r in lists[f"bilateral_{arm}"]] for arm in ("PSM1", "PSM2")
        },
    }
    for variant, arms in per_arm.items():
        for arm, expected in arms.items():
            simulated = [(start, goal) for who, start, goal in transfers(variant) if who == arm]
            assert simulated == expected, (variant, arm)
