"""Predict the cells a fit never saw: a predictive interval per cell that carries the fitted parameter's
uncertainty (worlds simulated across its posterior over the profile between grid values), each world's
simulated rate (from a finite number of simulated transfers) and the cell's own binomial draw, and whether
the real count falls inside. A real cell that placed every transfer (the paper's calibrated and optimised
rows) is simulated at the best value until no failure there would show it keeps `KEEPS` success (Wilson's
lower bound): a fitted world that helps the uncalibrated arm must not cost the calibrated one its grasps."""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass, replace

import numpy as np
from scipy import stats

from pegbt.sim.world_effects import WorldEffects
from pegbt.sim2real.outcomes.cells import Cell
from pegbt.sim2real.outcomes.fit import Profile
from pegbt.sim2real.outcomes.intervals import mixture_pmf, predictive_interval, rate_interval
from pegbt.sim2real.outcomes.simulate import CATEGORIES, Key, Mapper, SimCounts, simulate_cells

NODES = 8  # worlds simulated per prediction, each standing for an equal share of the parameter's posterior
KEEPS = 0.98  # the success a world must keep where the real robot placed every transfer
PREDICT_SEED = 10_000  # the predictions' simulated transfers: seeds the fit never scored
Z = float(stats.norm.ppf(0.975))


def transfers_to_keep(level: float = KEEPS) -> int:
    """The fewest transfers whose Wilson 95 % lower bound reaches `level` when every one is placed
    (n / (n + z²) ≥ `level`): 189 for 98 %."""
    return math.ceil(level * Z**2 / (1.0 - level))


@dataclass(frozen=True)
class Prediction:
    """A cell's predicted rate, its 95 % predictive interval, whether the real count is inside, and the
    simulated rate at the best value."""

    rate: float
    low: float
    high: float
    inside: bool
    at_best: SimCounts

    @property
    def keeps(self) -> float:
        """The Wilson 95 % lower bound of the rate simulated at the best value."""
        return rate_interval(self.at_best.succeeded, self.at_best.attempted, method="wilson")[0]


def _mixture(cell: Cell, sims: Sequence[SimCounts], weights: np.ndarray) -> np.ndarray:
    table = np.array([[s.succeeded, s.attempted] for s in sims], dtype=float)
    return mixture_pmf(cell.attempted, table, weights)


def nodes(values: np.ndarray, weights: np.ndarray, count: int = NODES) -> tuple[np.ndarray, np.ndarray]:
    """`count` values standing for a posterior over `values` (`weights` summing to 1), an equal share of it
    each: its (i + ½) / `count` quantiles, a value picked twice weighing twice. A posterior within one
    value needs one world; one spread between grid values, or over both signs of a registration offset,
    gets worlds across it. The best grid value alone is not enough: a held-out cell can change within a
    grid step (a registration offset of 2.5 mm drops every calibrated handover that 2.0 mm places half of)."""
    picks = np.minimum(np.searchsorted(np.cumsum(weights), (np.arange(count) + 0.5) / count), len(values) - 1)
    unique, drawn = np.unique(picks, return_counts=True)
    return values[unique], drawn / count


def predict(
    mapper: Mapper,
    profiles: Sequence[Profile],
    cells: Sequence[Cell],
    transfers: int,
    count: int = NODES,
    shares: Sequence[float] | np.ndarray | None = None,
    best_value: bool = True,
) -> tuple[dict[Key, Prediction], list[dict[Key, Prediction]]]:
    """Each of `cells` predicted by `profiles` mixed (equally, or by `shares`: effects the data cannot tell
    apart), each from its posterior over the fit cells (`count` worlds of it, simulated); and the prediction
    of each profile alone. `best_value`: each cell is also simulated at the profile's best value, a cell
    placed in full on to `transfers_to_keep()` (`_keep_up`), and the mixture's `Prediction.at_best` pools the
    profiles' best values by their shares; without (a prediction over a range has no best value to keep),
    `Prediction.at_best` holds the worlds' transfers pooled by their weights (the mixture's: every
    profile's, by `shares`; `weighted_pool`)."""
    keys = [c.key for c in cells]
    share = np.full(len(profiles), 1.0 / len(profiles)) if shares is None else np.asarray(shares, dtype=float)
    pmfs: dict[Key, list[np.ndarray]] = {key: [] for key in keys}
    best: list[dict[Key, SimCounts]] = []
    drawn: list[tuple[dict[Key, SimCounts], float]] = []  # every world the mixture draws on, and its weight
    for fitted, part in zip(profiles, share):
        values, weights = nodes(*fitted.posterior(), count=count)
        worlds = [fitted.candidate.world(float(v), fitted.base) for v in values]
        if best_value:
            *sims, at_best = simulate_cells(mapper, [*worlds, fitted.world()], keys, transfers, PREDICT_SEED)
            _keep_up(mapper, fitted, cells, transfers, at_best)
        else:
            sims = simulate_cells(mapper, worlds, keys, transfers, PREDICT_SEED)
            at_best = {key: weighted_pool([(s[key], w) for s, w in zip(sims, weights)]) for key in keys}
        best.append(at_best)
        drawn += [(sim, part * weight) for sim, weight in zip(sims, weights)]
        for cell in cells:
            pmfs[cell.key].append(_mixture(cell, [s[cell.key] for s in sims], weights))
    each = [
        {c.key: _prediction(c, pmfs[c.key][k], best[k][c.key]) for c in cells} for k in range(len(profiles))
    ]
    mixed = {
        c.key: _prediction(
            c,
            np.tensordot(share, np.array(pmfs[c.key]), axes=1),
            _pooled_after(c.key, best, share)
            if best_value
            else weighted_pool([(s[c.key], w) for s, w in drawn]),
        )
        for c in cells
    }
    return mixed, each


def _pooled_after(key: Key, best: Sequence[dict[Key, SimCounts]], share: np.ndarray) -> SimCounts:
    """What a mixture of profiles simulates after in cell `key`: one profile's best value as simulated; tied
    profiles' best values pooled by their shares, so no tied world stands for the others."""
    if len(best) == 1:
        return best[0][key]
    return weighted_pool([(b[key], float(w)) for b, w in zip(best, share)])


def weighted_pool(drawn: Sequence[tuple[SimCounts, float]]) -> SimCounts:
    """The simulated transfers of several worlds as one, each world weighing its share of a mixture (or of a
    posterior): the category shares averaged by weight and scaled to the pool's effective number of
    transfers (Kish's, 1 / Σ (wₖ² / nₖ), the weights normalised), so a world of no weight adds nothing and a
    mixture that one world dominates claims no more transfers than that world simulated. Where a prediction
    has no best value to simulate (it spans open effects' ranges), this is what it simulates after."""
    kept = [(sim, w) for sim, w in drawn if w > 0 and sim.attempted > 0]
    if not kept:
        return SimCounts()
    sims = [sim for sim, _ in kept]
    w = np.array([weight for _, weight in kept], dtype=float)
    w /= w.sum()
    n = np.array([sim.attempted for sim in sims], dtype=float)
    effective = 1.0 / float((w**2 / n).sum())
    shares = w @ (np.array([sim.vector() for sim in sims]) / n[:, None])
    placed = w * np.array([sim.succeeded for sim in sims]) / n  # each world's share of the pool's placed
    return SimCounts(
        counts={c: int(round(x * effective)) for c, x in zip(CATEGORIES, shares)},
        seconds=float(w @ [sim.seconds for sim in sims]),
        placed_seconds=float(placed @ [sim.placed_seconds for sim in sims] / placed.sum())
        if placed.sum() > 0
        else 0.0,
        skipped=int(round(effective * float(w @ (np.array([sim.skipped for sim in sims]) / n)))),
    )


def _keep_up(
    mapper: Mapper, fitted: Profile, cells: Sequence[Cell], transfers: int, at_best: dict[Key, SimCounts]
) -> None:
    """More transfers at the best value for every cell the real robot placed in full, to
    `transfers_to_keep()` in all (other seeds than the mixture's)."""
    full = [c.key for c in cells if _full(c)]
    extra = transfers_to_keep() - transfers
    if not full or extra <= 0:
        return
    more = simulate_cells(mapper, [fitted.world()], full, extra, first_seed=PREDICT_SEED + transfers)[0]
    for key, counts in more.items():
        at_best[key].merge(counts)


def predict_world(
    mapper: Mapper, world: WorldEffects, cells: Sequence[Cell], transfers: int
) -> dict[Key, Prediction]:
    """Each of `cells` as one world predicts it (its simulated rate and the cell's binomial draw), on the
    seeds `predict` uses."""
    sims = simulate_cells(mapper, [world], [c.key for c in cells], transfers, first_seed=PREDICT_SEED)[0]
    return {c.key: _prediction(c, _mixture(c, [sims[c.key]], np.ones(1)), sims[c.key]) for c in cells}


def predict_null(
    mapper: Mapper, null_sims: dict[Key, SimCounts], cells: Sequence[Cell]
) -> dict[Key, Prediction]:
    """Each of `cells` as the default world predicts it (simulation noise and the binomial draw only).
    A cell the real robot placed in full is simulated on, past the seeds `null_sims` holds (one transfer,
    attempted or skipped, per seed), to `transfers_to_keep()` in all, as a fitted world's are (`_keep_up`):
    with nothing named the calibrated rows must still show they keep `KEEPS`."""
    kept = {key: replace(counts, counts=dict(counts.counts)) for key, counts in null_sims.items()}
    seeds = {c.key: null_sims[c.key].attempted + null_sims[c.key].skipped for c in cells if _full(c)}
    for n in sorted(set(seeds.values())):
        if transfers_to_keep() > n:
            full = [key for key, simulated in seeds.items() if simulated == n]
            more = simulate_cells(mapper, [WorldEffects()], full, transfers_to_keep() - n, first_seed=n)[0]
            for key, counts in more.items():
                kept[key].merge(counts)
    return {c.key: _prediction(c, _mixture(c, [null_sims[c.key]], np.ones(1)), kept[c.key]) for c in cells}


def _full(cell: Cell) -> bool:
    """Whether the real robot placed every transfer of `cell` it attempted."""
    return bool(cell.attempted) and cell.succeeded == cell.attempted


def _prediction(cell: Cell, pmf: np.ndarray, at_best: SimCounts) -> Prediction:
    rate, low, high = predictive_interval(pmf)
    real = cell.rate
    return Prediction(rate, low, high, bool(low - 1e-9 <= real <= high + 1e-9), at_best)
