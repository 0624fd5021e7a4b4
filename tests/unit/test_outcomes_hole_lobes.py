"""The hole's lobes act in the phase simulator where the default world misses: on world 7000, the handover
uncalibrated under the paper's protocol, transfer 4 (peg 5 handed over to peg 11) strikes its goal peg
2.0 mm off the round hole's axis at its first attempt; with the paper's block's lobes (4.5 mm,
`img/block.pcd`, BerkeleyAutomation/FLSpegtransferHO) the peg finds room towards a corner and the block is
placed (docs/guides/sim-to-real.md, "The paper's block has a lobed hole")."""

from __future__ import annotations

from pegbt.sim.world_effects import WorldEffects
from pegbt.sim2real.outcomes.phasesim import Replay, simulate_transfer

SEED, INDEX = 7000, 4
LOBES = WorldEffects.of({"hole_lobes": {"lobe_radius": 0.0045}})


def test_the_lobes_place_the_handover_the_round_hole_fails_at_lower() -> None:
    replay = Replay()
    args = ("handover", "uncalibrated", SEED, replay)
    default = simulate_transfer(WorldEffects(), *args, index=INDEX, attempts=1, registered=True)
    lobed = simulate_transfer(LOBES, *args, index=INDEX, attempts=1, registered=True)
    assert (default.succeeded, default.phase) == (False, "lower")
    assert lobed.succeeded
