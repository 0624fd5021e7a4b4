"""Chamfer capture acts in the phase simulator where it acts in a whole trial: on world 501, the unilateral
task uncalibrated, transfer 4 (peg 5 to 11) strikes its goal peg 2–4 mm off the axis when lowered; with
the chamfers at the top of their range (4 mm) the trial's tick log placed it (`pegbt eval --world-effects`,
2026-11-29), and so must the phase simulator, where the default world fails it at `lower`."""

from __future__ import annotations

from pegbt.sim.world_effects import WorldEffects
from pegbt.sim2real.outcomes.phasesim import Replay, simulate_transfer

SEED, INDEX = 501, 4
CHAMFERS = WorldEffects.of({"chamfer_capture": {"capture_radius": 0.004}})


def test_the_chamfers_place_the_transfer_the_default_world_fails_at_lower() -> None:
    replay = Replay()
    default = simulate_transfer(WorldEffects(), "unilateral", "uncalibrated", SEED, replay, index=INDEX)
    caught = simulate_transfer(CHAMFERS, "unilateral", "uncalibrated", SEED, replay, index=INDEX)
    assert (default.succeeded, default.phase) == (False, "lower")
    assert caught.succeeded
