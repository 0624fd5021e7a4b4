"""`pegbt bench sim2real-outcomes`'s families: each registered world effect concealed alone, at a value in
its range that acts, through a parameter the fit searches (else its error could not be scored)."""

from __future__ import annotations

import pytest

from pegbt.bench.sim2real_outcomes import FAMILIES
from pegbt.sim.world_effects import WORLD_EFFECT_KINDS, WorldEffects
from pegbt.sim2real.outcomes.fit import FITTED


def test_every_registered_effect_is_concealed_alone_in_a_family() -> None:
    alone = {next(iter(hidden)) for hidden in FAMILIES.values() if len(hidden) == 1}
    assert alone == set(WORLD_EFFECT_KINDS)
    assert {} in FAMILIES.values()


@pytest.mark.parametrize("family", list(FAMILIES))
def test_a_family_is_a_valid_world_whose_concealed_values_act_and_are_fitted(family: str) -> None:
    world = WorldEffects.of(FAMILIES[family])  # its ranges checked: a PegbtError if not
    assert [effect.kind for effect in world] == list(FAMILIES[family])
    for kind, values in FAMILIES[family].items():
        parameters = WORLD_EFFECT_KINDS[kind].parameters
        for name, value in values.items():
            assert value != parameters[name].default, f"{kind}.{name} at its inert default"
            assert name in FITTED[kind], f"{kind}.{name} is not a parameter the fit searches"
