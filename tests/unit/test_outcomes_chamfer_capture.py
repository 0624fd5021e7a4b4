"""Chamfer capture acts in the phase simulator where it acts in a whole trial: on world 503, the unilateral
task uncalibrated, transfer 3 (peg 2 to 9) strikes its goal peg when lowered; with the chamfers at the top
of their range (4 mm) the trial's first lowering was caught 2.1 mm off the axis and the block placed
(`pegbt eval --variant unilateral --condition uncalibrated --trials 1 --seed 503 --world-effects W
--keep-logs`, branch bilat, 2026-11-29; without W it struck peg 9), and so must the phase simulator, where
the default world fails it at `lower`."""

from __future__ import annotations

from pegbt.sim.world_effects import WorldEffects
from pegbt.sim2real.outcomes.phasesim import Replay, simulate_transfer

SEED, INDEX = 503, 3
CHAMFERS = WorldEffects.of({"chamfer_capture": {"capture_radius": 0.004}})


def test_the_chamfers_place_the_transfer_the_default_world_fails_at_lower() -> None:
    replay = Replay()
    default = simulate_transfer(WorldEffects(), "unilateral", "uncalibrated", SEED, replay, index=INDEX)
    caught = simulate_transfer(CHAMFERS, "unilateral", "uncalibrated", SEED, replay, index=INDEX)
    assert (default.succeeded, default.phase) == (False, "lower")
    assert caught.succeeded
