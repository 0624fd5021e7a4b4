"""`pegbt bench sim2real-outcomes`'s families: each registered world effect concealed alone, at a value in
its range that acts, through a parameter the fit searches (else its error could not be scored), and between
the fit's grid values: a value on the grid would let a fit that names the best grid value score a parameter
error of 0 without reading the profile between grid values (`fit.estimate`)."""

from __future__ import annotations

import math

import pytest

from pegbt.bench.sim2real_outcomes import FAMILIES, SETTINGS
from pegbt.sim.world_effects import WORLD_EFFECT_KINDS, WorldEffects
from pegbt.sim2real.outcomes.fit import FITTED, candidates

GRIDS = {(c.kind, c.parameter): sorted(c.grid) for c in candidates(SETTINGS.points)}


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


@pytest.mark.parametrize("family", [f for f in FAMILIES if FAMILIES[f]])
def test_each_concealed_value_lies_between_grid_values(family: str) -> None:
    for kind, values in FAMILIES[family].items():
        for name, value in values.items():
            grid = GRIDS[(kind, name)]
            spaced = grid[0] > 0 and grid[-1] / grid[0] > 100  # log-spaced, as `candidates` lays it
            at = [math.log(g) for g in grid] if spaced else grid
            x = math.log(value) if spaced else value
            step = min(b - a for a, b in zip(at, at[1:]))
            assert min(abs(x - g) for g in at) >= 0.1 * step, f"{kind}.{name} {value} on the grid {grid}"
