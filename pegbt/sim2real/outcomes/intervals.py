"""Binomial statistics of outcome counts: intervals, the test of a disagreement, and predictive intervals.

The simulator's rates are themselves estimated from a finite number of simulated transfers, so a count
observed under a simulated rate is beta-binomial (the rate's Jeffreys posterior mixed over), not binomial.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Literal

import numpy as np
from numpy.typing import NDArray
from scipy import stats

LEVEL = 0.95


def rate_interval(
    succeeded: int, attempted: int, level: float = LEVEL, method: Literal["exact", "wilson"] = "exact"
) -> tuple[float, float]:
    """The interval of a success rate, exact (Clopper–Pearson) by default: the paper's 37/68 gives about
    42–66 %; "wilson" for the bound a simulated rate is held to (`predict.transfers_to_keep`)."""
    if attempted == 0:
        return 0.0, 1.0
    ci = stats.binomtest(succeeded, attempted).proportion_ci(confidence_level=level, method=method)
    return float(ci.low), float(ci.high)


def disagreement_p(real: tuple[int, int], simulated: tuple[int, int]) -> float:
    """Two-sided p-value that the real and simulated (succeeded, attempted) counts share one rate (Fisher's
    exact test)."""
    (k_real, n_real), (k_sim, n_sim) = real, simulated
    if n_real == 0 or n_sim == 0:
        return 1.0
    table = np.array([[k_real, n_real - k_real], [k_sim, n_sim - k_sim]])
    return float(stats.fisher_exact(table).pvalue)


def least_p(real: tuple[int, int], simulated: tuple[int, int]) -> float:
    """The smallest p-value `disagreement_p` can give with these margins (attempted on each side, and
    succeeded on both together), at either end of the counts' range: a row whose every transfer placed on
    both sides (or none) can never disagree, whatever the world."""
    (k_real, n_real), (k_sim, n_sim) = real, simulated
    total = k_real + k_sim
    ends = {max(0, total - n_sim), min(total, n_real)}
    return min(disagreement_p((k, n_real), (total - k, n_sim)) for k in ends)


def beyond_chance_testable(
    p_values: Sequence[float], least: Sequence[float], level: float = LEVEL
) -> list[bool]:
    """`beyond_chance` over the tests that can reject at all (`least` p-value at most 1 − `level`); the
    others, which cannot, are not counted among the many (Tarone 1990, Biometrics 46:515; for the false
    discovery rate, Gilbert 2005, J. R. Stat. Soc. C 54:143)."""
    testable = [i for i, low in enumerate(least) if low <= 1.0 - level]
    flags = beyond_chance([p_values[i] for i in testable], level)
    out = [False] * len(p_values)
    for i, flag in zip(testable, flags):
        out[i] = flag
    return out


def beyond_chance(p_values: Sequence[float], level: float = LEVEL) -> list[bool]:
    """Which of many tests reject at the false discovery rate 1 − `level` (Benjamini–Hochberg)."""
    if not p_values:
        return []
    adjusted = stats.false_discovery_control(np.asarray(p_values, dtype=float))
    return [bool(p <= 1.0 - level) for p in adjusted]


def count_log_likelihood(succeeded: int, attempted: int, sim_succeeded: float, sim_attempted: float) -> float:
    """log P(`succeeded` of `attempted` | the simulator placed `sim_succeeded` of `sim_attempted`)."""
    a, b = sim_succeeded + 0.5, sim_attempted - sim_succeeded + 0.5
    return float(stats.betabinom.logpmf(succeeded, attempted, a, b))


def mixture_pmf(
    attempted: int, sim: NDArray[np.float64], weights: NDArray[np.float64]
) -> NDArray[np.float64]:
    """P(k) for k = 0..`attempted` under a mixture of simulated rates: `sim` (m, 2) rows of (succeeded,
    attempted) per parameter value, `weights` (m,) their posterior weights (parameter uncertainty)."""
    k = np.arange(attempted + 1)
    pmf = np.zeros(attempted + 1)
    for (s, n), w in zip(sim, weights / weights.sum()):
        if w > 0:
            pmf += w * stats.betabinom.pmf(k, attempted, s + 0.5, n - s + 0.5)
    return pmf / pmf.sum()


def predictive_interval(pmf: NDArray[np.float64], level: float = LEVEL) -> tuple[float, float, float]:
    """Mean rate and the central `level` interval of rates from a count's predictive pmf over 0..n."""
    n = len(pmf) - 1
    cdf = np.cumsum(pmf)
    tail = (1.0 - level) / 2
    low = int(np.searchsorted(cdf, tail - 1e-12))
    high = int(np.searchsorted(cdf, 1.0 - tail - 1e-12))
    mean = float(pmf @ np.arange(n + 1)) / n if n else float("nan")
    return mean, low / max(n, 1), min(high, n) / max(n, 1)
