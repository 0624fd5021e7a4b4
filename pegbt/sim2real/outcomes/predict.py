"""Predict the cells a fit never saw: a predictive interval per cell from the fitted parameter's posterior
(the grid values the fit cells weigh) mixed with each value's simulated rate and the cell's own binomial
draw, and whether the real count falls inside."""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from pegbt.sim2real.outcomes.cells import Cell
from pegbt.sim2real.outcomes.fit import Profile
from pegbt.sim2real.outcomes.intervals import mixture_pmf, predictive_interval
from pegbt.sim2real.outcomes.simulate import Key, Mapper, SimCounts, simulate_cells

MIN_WEIGHT = 0.02  # grid values weighing less than this (relative to the best) are not simulated to predict


@dataclass(frozen=True)
class Prediction:
    """A cell's predicted rate, its 95 % predictive interval, whether the real count is inside, and the
    simulated rate at the best value."""

    rate: float
    low: float
    high: float
    inside: bool
    at_best: SimCounts


def _mixture(cell: Cell, sims: Sequence[SimCounts], weights: np.ndarray) -> np.ndarray:
    table = np.array([[s.succeeded, s.attempted] for s in sims], dtype=float)
    return mixture_pmf(cell.attempted, table, weights)


def predict(
    mapper: Mapper, profiles: Sequence[Profile], cells: Sequence[Cell], transfers: int
) -> tuple[dict[Key, Prediction], list[dict[Key, Prediction]]]:
    """Each of `cells` predicted by `profiles` mixed equally (several: effects the data cannot tell apart),
    each from its posterior over the fit cells; and the prediction of each profile alone."""
    pmfs: dict[Key, list[np.ndarray]] = {c.key: [] for c in cells}
    best: list[dict[Key, SimCounts]] = []
    for fitted in profiles:
        weights = fitted.weights()
        keep = [i for i, w in enumerate(weights) if w >= MIN_WEIGHT * weights.max()]
        worlds = [fitted.candidate.world(fitted.values[i], fitted.base) for i in keep]
        sims = simulate_cells(mapper, worlds, [c.key for c in cells], transfers, first_seed=10_000)
        best.append(sims[keep.index(fitted.best)])
        for cell in cells:
            pmfs[cell.key].append(_mixture(cell, [s[cell.key] for s in sims], weights[keep]))
    each = [
        {c.key: _prediction(c, pmfs[c.key][k], best[k][c.key]) for c in cells} for k in range(len(profiles))
    ]
    mixed = {c.key: _prediction(c, np.mean(pmfs[c.key], axis=0), best[0][c.key]) for c in cells}
    return mixed, each


def predict_null(null_sims: dict[Key, SimCounts], cells: Sequence[Cell]) -> dict[Key, Prediction]:
    """Each of `cells` as the default world predicts it (simulation noise and the binomial draw only)."""
    return {
        c.key: _prediction(c, _mixture(c, [null_sims[c.key]], np.ones(1)), null_sims[c.key]) for c in cells
    }


def _prediction(cell: Cell, pmf: np.ndarray, at_best: SimCounts) -> Prediction:
    rate, low, high = predictive_interval(pmf)
    real = cell.rate
    return Prediction(rate, low, high, bool(low - 1e-9 <= real <= high + 1e-9), at_best)
