"""A larger real campaign is diagnosed with a simulated side grown in proportion (`Settings.for_campaign`):
the defaults are the concealed campaign's (120 real transfers a fit cell) and stay as they are there."""

from __future__ import annotations

import pytest

from pegbt.sim.world_effects import WorldEffects
from pegbt.sim2real.outcomes.cells import Cell, Outcomes
from pegbt.sim2real.outcomes.diagnose import Settings, diagnose
from tests.outcomes_helpers import fake_mapper, real_counts

SETTINGS = Settings(fit="unilateral", transfers=12, located=48, points=4)
HIDDEN = WorldEffects.of({"peg_compliance": {"deflection": 0.0012}})


def _outcomes(fit_transfers: int) -> Outcomes:
    """The stand-in robot with a bending peg: `fit_transfers` in each unilateral cell, 120 in the others."""
    cells = []
    for v in ("unilateral", "bilateral", "handover"):
        for c in ("uncalibrated", "calibrated"):
            n = fit_transfers if v == "unilateral" else 120
            placed = real_counts(HIDDEN, v, c, n, seed=7)
            cells.append(Cell(v, c, n, placed, 4.0, {"lift": n - placed} if n > placed else {}))
    return Outcomes(tuple(cells), "stand-in robot")


@pytest.mark.parametrize("real", [40, 75, 120])
def test_up_to_the_concealed_campaigns_size_the_settings_are_unchanged(real: int) -> None:
    assert SETTINGS.for_campaign(real) is SETTINGS
    assert diagnose(_outcomes(real), SETTINGS, fake_mapper).settings == SETTINGS


def test_a_larger_campaign_grows_the_simulated_side_in_proportion() -> None:
    """1,104 real transfers, 9.2 times 120: 12 → 111 simulated a world, 48 → 442 located."""
    grown = SETTINGS.for_campaign(1104)
    assert (grown.transfers, grown.located, grown.real) == (111, 442, 1104)
    assert grown.for_campaign(1104) is grown and grown.for_campaign(600) is grown


def test_the_diagnosis_sizes_itself_by_its_largest_fit_cell() -> None:
    """Unilateral cells of 480 real transfers (held-out ones of 120): the default world is located on four
    times the transfers in every fit cell, the calibrated one that agrees with it too, and the fit screens
    on four times as many a world."""
    d = diagnose(_outcomes(480), SETTINGS, fake_mapper)
    assert (d.settings.transfers, d.settings.located) == (48, 192)
    assert d.before[("unilateral", "uncalibrated")].attempted == 192
    assert d.before[("unilateral", "calibrated")].attempted == 192
    assert d.before[("bilateral", "uncalibrated")].attempted == 48
    screened = {
        p.candidate.kind: p.sims[0][("unilateral", "uncalibrated")].attempted for p in d.verdict.tried
    }
    assert screened.pop("peg_compliance") == 192  # the one leader, weighed as the default world is located
    assert set(screened.values()) == {48}
