"""Held-out cells predicted across the fitted parameter's posterior, not at its best grid value alone: a
cell that changes within a grid step must find the truth inside its interval, and a cell the parameter
does not move must keep the interval one world gives it."""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np
import pytest

from pegbt.sim2real.outcomes.cells import Cell
from pegbt.sim2real.outcomes.fit import Candidate, Profile
from pegbt.sim2real.outcomes.phasesim import TransferResult
from pegbt.sim2real.outcomes.predict import nodes, predict, predict_world, weighted_pool
from pegbt.sim2real.outcomes.simulate import CATEGORIES, SimCounts, Task

STEP = 0.0012  # deflection (m) from which the stand-in's bilateral transfers all fail at the lowering
GRID = (0.00075, 0.0015, 0.00225, 0.003)  # peg deflection's grid at `points=4`, less its inert default


def _step(tasks: Sequence[Task]) -> list[list[TransferResult]]:
    """A bilateral transfer is placed below `STEP` and fails above it; a handover is placed on even seeds
    in every world."""
    out = []
    for worlds, variant, _, seed in tasks:
        row = []
        for effects in worlds:
            bends = effects.values("peg_compliance")["deflection"] >= STEP
            placed = not bends if variant == "bilateral" else seed % 2 == 0
            row.append(TransferResult(placed, None if placed else "lower", 4.0))
        out.append(row)
    return out


def _profile(centre: float, spread: float) -> Profile:
    """A fit of peg deflection whose profile between grid values is a normal log-likelihood."""
    dense = np.linspace(GRID[0], GRID[-1], 3 * 16 + 1)
    at = np.array(GRID)
    per_cell = (-(((at - centre) / spread) ** 2) / 2)[:, None]
    candidate = Candidate("peg_compliance", "deflection", GRID)
    return Profile(candidate, GRID, [], per_cell, dense=(dense, -(((dense - centre) / spread) ** 2) / 2))


CELLS = [Cell("bilateral", "uncalibrated", 40, 40), Cell("handover", "uncalibrated", 40, 20)]


def test_a_cell_that_changes_within_a_grid_step_is_predicted_across_the_posterior() -> None:
    """Truth 1.0 mm places every bilateral transfer; the best grid value, 1.5 mm, places none, and the
    profile between grid values (0.9–1.9 mm at 95 %) holds both: the interval must hold the real count."""
    fitted = _profile(0.0014, 0.00025)
    assert fitted.value == 0.0015
    at_best = predict_world(_step, fitted.world(), CELLS, 12)[CELLS[0].key]
    assert not at_best.inside  # the best grid value alone misses it
    mixed, _ = predict(_step, [fitted], CELLS, 12)
    assert mixed[CELLS[0].key].inside and mixed[CELLS[0].key].high == 1.0
    assert mixed[CELLS[0].key].low == 0.0  # the posterior's worlds above 1.2 mm place none
    assert mixed[CELLS[0].key].at_best.succeeded == 0  # the best grid value is still what the fit simulated


def test_a_cell_the_parameter_does_not_move_keeps_one_worlds_interval() -> None:
    fitted = _profile(0.0014, 0.00025)
    mixed, _ = predict(_step, [fitted], CELLS, 12)
    alone = predict_world(_step, fitted.world(), CELLS, 12)[CELLS[1].key]
    handover = mixed[CELLS[1].key]
    assert (handover.low, handover.high) == (alone.low, alone.high)
    assert handover.inside


def test_nodes_stand_for_equal_shares_of_the_posterior() -> None:
    values = np.linspace(-1.0, 1.0, 9)
    sharp = np.zeros(9)
    sharp[6] = 1.0
    assert nodes(values, sharp)[0].tolist() == [0.5]
    assert nodes(values, sharp)[1].tolist() == [1.0]
    both = np.zeros(9)
    both[[1, 7]] = [0.25, 0.75]  # a registration offset of either sign, one three times as likely
    picked, weights = nodes(values, both, count=8)
    assert picked.tolist() == [-0.75, 0.75]
    assert weights.tolist() == pytest.approx([0.25, 0.75])


def _counts(placed: int, lift: int, seconds: float) -> SimCounts:
    counts = dict.fromkeys(CATEGORIES, 0) | {"placed": placed, "lift": lift}
    return SimCounts(counts=counts, seconds=seconds, placed_seconds=seconds)


def test_a_weighted_pool_weighs_each_world_by_its_share_and_claims_its_effective_transfers() -> None:
    """Two worlds of 100 transfers, one placing 90 and one 10: pooled 3 : 1 the rate is 70 %, on Kish's
    effective 160 transfers (1 / (0.75² / 100 + 0.25² / 100)); a world of no weight adds nothing; the
    seconds of a placed transfer are weighed by where the placed transfers come from."""
    good, bad = _counts(90, 10, 4.0), _counts(10, 90, 8.0)
    pooled = weighted_pool([(good, 3.0), (bad, 1.0)])
    assert pooled.attempted == 160
    assert pooled.rate == pytest.approx(0.70)
    assert pooled.seconds == pytest.approx(5.0)
    assert pooled.placed_seconds == pytest.approx(
        (0.75 * 0.9 * 4.0 + 0.25 * 0.1 * 8.0) / (0.75 * 0.9 + 0.25 * 0.1)
    )
    alone = weighted_pool([(good, 1.0), (bad, 0.0)])
    assert alone.counts == good.counts
    assert weighted_pool([(good, 0.0)]).attempted == 0


def test_tied_profiles_simulate_after_at_their_best_values_pooled() -> None:
    """Two tied fits, one bending the peg too little to fail a bilateral lowering and one past it: what
    the tie simulates after is both best values by their shares, not the first tied world alone."""
    low, high = _profile(0.00075, 0.0002), _profile(0.003, 0.0002)
    mixed, each = predict(_step, [low, high], CELLS, 12, shares=[0.75, 0.25])
    key = CELLS[0].key
    assert each[0][key].at_best.rate == 1.0 and each[1][key].at_best.rate == 0.0
    assert mixed[key].at_best.rate == pytest.approx(0.75, abs=0.01)
