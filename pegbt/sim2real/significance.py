"""Guards against false discoveries: circular-shift nulls, block jackknife, block bootstrap.

A candidate regressor that is smooth in time will line up with smooth (autocorrelated) noise by
chance far more often than an F-test assumes. The circular-shift null keeps both series' own
autocorrelation and breaks only their alignment: shift the residual by τ (wrapping around), score the
candidate exactly as for real, and see how often a shifted residual does as well. All shifts are
scored at once with FFT cross-correlations, per held-out fold and per width on the grid, so the null
distribution covers the same "best width" search the real statistic made.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray
from scipy import stats

Array = NDArray[np.float64]

MIN_SHIFT_FRACTION = 0.1  # shifts closer than this to zero (either way) would keep the signal aligned
TAIL_EXCEEDANCES = 10
TAIL_FRACTION = 0.1


def heldout_gain_all_shifts(residual: Array, columns: Array, fold_ranges: list[tuple[int, int]]) -> Array:
    """Held-out gain fraction of regressing the residual on each column, for every circular shift.

    For each shift τ and column g, the coefficient is fitted on the training folds of the shifted
    residual and scored on each held-out fold; the gains are summed over folds and divided by the
    residual energy. Returns (n_shifts, G); row 0 is the unshifted (observed) statistic.
    """
    e = residual - residual.mean()
    phi = columns - columns.mean(0)
    n = len(e)
    spectrum = np.fft.rfft(e)
    cross = np.empty((len(fold_ranges), n, phi.shape[1]))
    energy = np.empty((len(fold_ranges), phi.shape[1]))
    for f, (a, b) in enumerate(fold_ranges):
        masked = np.zeros_like(phi)
        masked[a:b] = phi[a:b]
        # sum_t masked(t) e(t + τ) for every τ: a circular cross-correlation.
        cross[f] = np.fft.irfft(np.conj(np.fft.rfft(masked, axis=0)) * spectrum[:, None], n=n, axis=0)
        energy[f] = (phi[a:b] ** 2).sum(0)
    total_cross = cross.sum(0)
    total_energy = energy.sum(0)
    gain = np.zeros((n, phi.shape[1]))
    for f in range(len(fold_ranges)):
        train_energy = np.maximum(total_energy - energy[f], 1e-300)
        theta = (total_cross - cross[f]) / train_energy
        gain += 2 * theta * cross[f] - theta**2 * energy[f]
    return gain / max(float(e @ e), 1e-300)


def shift_pvalue(residual: Array, columns: Array, fold_ranges: list[tuple[int, int]]) -> tuple[float, float]:
    """(observed statistic, p-value) of the best-width candidate against its circular-shift null.

    The p-value is the fraction of shifts that score at least as well. When fewer than
    `TAIL_EXCEEDANCES` do, counting cannot resolve it (a short recording has few shifts, and the
    Bonferroni level is small), so the upper tail of the null is modelled as exponential beyond its
    90th percentile (a generalised Pareto tail of shape 0, heavier than a normal one: conservative).
    """
    scores = heldout_gain_all_shifts(residual, columns, fold_ranges).max(axis=1)
    n = len(scores)
    lo = int(np.ceil(MIN_SHIFT_FRACTION * n))
    null = scores[lo : n - lo + 1]
    observed = float(scores[0])
    exceed = int((null >= observed).sum())
    if exceed >= TAIL_EXCEEDANCES:
        return observed, (1 + exceed) / (1 + len(null))
    threshold = float(np.quantile(null, 1 - TAIL_FRACTION))
    excess = null[null > threshold] - threshold
    scale = float(excess.mean()) if excess.size else 1e-300
    return observed, TAIL_FRACTION * float(np.exp(-(observed - threshold) / max(scale, 1e-300)))


def t_pvalue(estimate: float, standard_error: float, dof: int) -> float:
    """Two-sided p-value of a coefficient given its (jackknife) standard error."""
    if standard_error <= 0:
        return 0.0 if estimate else 1.0
    return float(2 * stats.t.sf(abs(estimate) / standard_error, dof))


def correlation_length(residual: Array) -> int:
    """Samples until the residual's autocorrelation first drops below 0.2 (the bootstrap block length)."""
    e = residual - residual.mean()
    n = len(e)
    spectrum = np.abs(np.fft.rfft(e, 2 * n)) ** 2
    acf = np.fft.irfft(spectrum)[:n]
    acf = acf / max(float(acf[0]), 1e-300)
    below = np.flatnonzero(acf < 0.2)
    return int(below[0]) if below.size else n


def block_bootstrap_indices(n: int, block: int, rng: np.random.Generator) -> NDArray[np.int64]:
    """Indices of a circular block bootstrap sample: random blocks of consecutive samples, wrapped."""
    block = int(np.clip(block, 1, max(1, n // 4)))
    starts = rng.integers(0, n, size=-(-n // block))
    return ((starts[:, None] + np.arange(block)[None, :]).reshape(-1)[:n]) % n
