"""The concealed worlds of `pegbt bench sim2real-outcomes` hold values the fit's grid does not: a value on the
grid would let a fit that names the best grid value score a parameter error of 0 without reading the profile
between grid values (`fit.estimate`)."""

from __future__ import annotations

import pytest

from pegbt.bench.sim2real_outcomes import FAMILIES, SETTINGS
from pegbt.sim.world_effects import WorldEffects
from pegbt.sim2real.outcomes.fit import candidates

GRIDS = {(c.kind, c.parameter): c.grid for c in candidates(SETTINGS.points)}


@pytest.mark.parametrize("family", [f for f in FAMILIES if FAMILIES[f]])
def test_each_concealed_value_lies_between_grid_values(family: str) -> None:
    WorldEffects.of(FAMILIES[family])  # a valid world, inside every range
    for kind, parameters in FAMILIES[family].items():
        for name, value in parameters.items():
            grid = sorted(GRIDS[(kind, name)])
            step = min(b - a for a, b in zip(grid, grid[1:]))
            assert min(abs(value - g) for g in grid) >= 0.1 * step, (family, name, value, grid)
