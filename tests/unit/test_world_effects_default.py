"""The default world is today's: with no world effects, or with every effect at its inert default, a scripted
trial with uncalibrated-sized errors gives the same events, outcome for outcome, as before the effects
existed (fingerprints recorded on main at 5c5ab95; seed 2's again at 51d7e1f, where a struck peg's event says
how far off the hole came down: with the old wording its events digest as before)."""

import pytest
from world_effects_helpers import digest, noisy_unilateral

from pegbt.sim.world import World
from pegbt.sim.world_effects import WORLD_EFFECT_KINDS, WorldEffects

# (seed, wrist give in m): fingerprint of the events and where the six blocks ended, on main before the effects
BEFORE = {
    (1, 0.0003): ("19d88f7de3a8516f", [6, 7, 2, 8, 10, 5]),
    (2, 0.0): ("cf79d524d792d985", [6, 1, None, 8, 4, 11]),
    (2, 0.0003): ("07a79efaed8d0d5c", [6, 1, None, 8, 10, 11]),
    (3, 0.0): ("6bbd966621c64b7d", [0, 1, 2, 8, 4, 11]),
}
INERT = WorldEffects.of({name: {} for name in WORLD_EFFECT_KINDS})


@pytest.mark.parametrize("effects", [WorldEffects(), INERT], ids=["none", "all-inert"])
@pytest.mark.parametrize(("seed", "give"), list(BEFORE))
def test_a_scripted_trial_in_the_default_world_is_what_it_was(seed, give, effects):
    world = World(seed, effects=effects)
    events = noisy_unilateral(world, seed, give)
    assert (digest(events), [block.peg for block in world.blocks]) == BEFORE[seed, give]
