"""The fitted parameter read from the profile log-likelihood between grid values, not the best grid value:
a maximum between grid values is found, and the profile's 95 % interval holds the truth."""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy import stats

from pegbt.sim.world_effects import WorldEffects
from pegbt.sim2real.outcomes.cells import Cell, Outcomes
from pegbt.sim2real.outcomes.diagnose import Settings, diagnose, profile_parameters
from pegbt.sim2real.outcomes.fit import between, candidates, estimate, with_inert
from pegbt.sim2real.outcomes.simulate import SimCounts
from tests.outcomes_helpers import fake_mapper, logged_cell

GRID = (0.00075, 0.0015, 0.00225, 0.003)  # peg deflection at `points=4`: 0.75 mm steps
KEY = ("unilateral", "uncalibrated")


def _rate(deflection: float) -> float:
    """A lift's success rising with the peg's deflection, not linearly."""
    return 0.1 + 0.7 / (1 + np.exp(-(deflection - 0.0015) / 0.0006))


def _sims(grid: tuple[float, ...], transfers: int) -> list[dict[tuple[str, str], SimCounts]]:
    out = []
    for value in grid:
        counts = SimCounts()
        counts.counts["placed"] = round(transfers * _rate(value))
        counts.counts["lift"] = transfers - counts.counts["placed"]
        out.append({KEY: counts})
    return out


@pytest.mark.parametrize("truth", [0.0011, 0.0015, 0.0019, 0.0026])
def test_a_maximum_between_grid_values_is_found_and_its_interval_holds_it(truth: float) -> None:
    real = 120
    placed = round(real * _rate(truth))
    cell = Cell(*KEY, real, placed, failures={"lift": real - placed})
    sims = _sims(GRID, 400)
    per_cell = np.zeros((len(GRID), 1))
    values, totals = between(GRID, sims, [cell], per_cell, phases=True)
    value, low, high = estimate(values, totals)
    assert abs(value - truth) <= 0.1 * truth
    assert low <= truth <= high
    assert values[0] == GRID[0] and values[-1] == GRID[-1]


def test_the_interval_is_where_the_profile_is_within_the_likelihood_ratio_bound() -> None:
    x = np.linspace(0.0, 4.0, 401)
    value, low, high = estimate(x, -((x - 2.0) ** 2) / 2)
    half = np.sqrt(stats.chi2.ppf(0.95, 1))
    assert value == pytest.approx(2.0)
    assert low == pytest.approx(2.0 - half, abs=2e-3) and high == pytest.approx(2.0 + half, abs=2e-3)


def test_nothing_is_extrapolated_beyond_the_grid() -> None:
    value, low, high = estimate(GRID, np.array([-30.0, -12.0, -4.0, 0.0]))
    assert value == GRID[-1] and high == GRID[-1] and GRID[-2] < low < GRID[-1]


def test_a_log_spaced_grid_is_interpolated_in_the_log_of_the_value() -> None:
    grid = tuple(float(v) for v in np.geomspace(100.0, 100_000.0, 4))
    values, _ = between(grid, _sims(grid, 10), [Cell(*KEY, 10, 5)], np.zeros((4, 1)), phases=False, steps=4)
    assert np.allclose(np.diff(np.log(values)), np.log(10.0) / 4)


def test_a_diagnosis_names_a_value_between_grid_values() -> None:
    """1.1 mm lies between 0.75 and 1.5 mm, each more than 30 % off: the named value is the estimate,
    and the world file's."""
    truth = 0.0011
    hidden = WorldEffects.of({"peg_compliance": {"deflection": truth}})
    keys = [(v, c) for v in ("unilateral", "bilateral", "handover") for c in ("uncalibrated", "calibrated")]
    outcomes = Outcomes(
        tuple(logged_cell(hidden, v, c, 400, 7 + i) for i, (v, c) in enumerate(keys)),
        "test",
    )
    d = diagnose(outcomes, Settings(fit="unilateral", transfers=300, points=4, phases=True), fake_mapper)
    (named,) = d.verdict.named
    assert min(abs(v - truth) for v in GRID) > 0.3 * truth
    refined = [v for v in named.values if not any(math.isclose(v, g) for g in GRID)]
    assert len(refined) >= 1 and all(GRID[0] < v < GRID[1] for v in refined)
    assert abs(named.estimate - truth) <= 0.3 * truth
    values, intervals = profile_parameters(named)
    assert values["deflection"] == named.estimate
    low, high = intervals["deflection"]
    assert low <= truth <= high
    assert d.world().values("peg_compliance")["deflection"] == named.estimate


def test_a_value_below_the_first_grid_value_is_read_through_the_inert_default() -> None:
    """0.5 mm lies between the inert default (0) and the grid's first value (0.75 mm): the profile runs
    through the default world's counts, so the estimate can fall below the grid and its interval holds it."""
    truth = 0.0005
    hidden = WorldEffects.of({"peg_compliance": {"deflection": truth}})
    outcomes = Outcomes(
        (
            logged_cell(hidden, "unilateral", "uncalibrated", 1000, 5),
            Cell("unilateral", "calibrated", 1000, 1000, failures={"lift": 0}),
        ),
        "test",
    )
    d = diagnose(outcomes, Settings(fit="unilateral", transfers=1000, located=1000, points=4), fake_mapper)
    (named,) = d.verdict.named
    assert named.estimate < GRID[0]
    low, high = named.interval()
    assert low <= truth <= high and high < GRID[1]


def test_the_inert_default_joins_the_grid_where_it_lies() -> None:
    (registration,) = [c for c in candidates(4) if c.name == "registration_offset.x"]
    sims = [{KEY: SimCounts()} for _ in registration.grid]
    default = {KEY: SimCounts()}
    values, joined = with_inert(registration, sims, default)
    assert values == [-0.005, -0.0025, 0.0, registration.grid[2], 0.005]
    assert joined[2] is default and joined[1] is sims[1] and joined[3] is sims[2]
