"""Guards against false discoveries: effective-sample-size tests, block jackknife, block bootstrap.

A candidate regressor that is smooth in time lines up with smooth (autocorrelated) noise by chance
far more often than an F-test assumes. Its correlation with the residual is therefore tested with
Student's t on N_eff − 2 degrees of freedom, where N_eff = 1 / var(r) comes from Bartlett's formula
var(r) = (1 + 2 Σ_k ρ_e(k) ρ_φ(k)) / N: the autocorrelations of the noise (the residual with the
candidate's best fit removed, so a real effect does not inflate its own null) and of the candidate,
summed over the lags where the noise is still correlated. This is the circular-shift null computed
analytically: the mean square of the correlations over all circular shifts is exactly that sum, and
the truncation drops the lags where it is pure estimation noise. Counting shifted correlations alone
cannot resolve the small p-values a Bonferroni level asks for in short recordings.
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np
from numpy.typing import NDArray
from scipy import stats

Array = NDArray[np.float64]

CORRELATED = 0.2  # the noise counts as correlated until its autocorrelation first drops below this
LAG_HORIZON = 10  # Bartlett's sum runs to this many times that correlation length


def autocorrelation(x: Array) -> Array:
    """Circular sample autocorrelation of each column of x (N, ...), lag 0 first."""
    x = x - x.mean(0)
    power = np.abs(np.fft.rfft(x, axis=0)) ** 2
    acf = np.fft.irfft(power, n=len(x), axis=0)
    return acf / np.maximum(acf[:1], 1e-300)


def effective_samples(noise: Array, column: Callable[[int], Array], count: int) -> Array:
    """N_eff of the correlation between the noise (N,) and each of `count` columns (`column(k)`, N), by
    Bartlett's formula; the columns are read one at a time, so a candidate is never held whole.

    The noise's autocorrelation enters twice: as measured (to the lag where it is still correlated,
    ×LAG_HORIZON) and as an AR(1) model with its lag-1 value; the larger variance is kept, because a
    sum of noisy sample autocorrelations can undershoot and make the test overconfident.
    """
    n = len(noise)
    rho_noise = autocorrelation(noise)
    below = np.flatnonzero(rho_noise < CORRELATED)
    horizon = int(min(n // 2, LAG_HORIZON * max(1, below[0] if below.size else n)))
    lags = np.arange(1, horizon + 1)
    modelled = np.clip(rho_noise[1], 0.0, 0.999) ** lags
    variance = np.empty(count)
    for k in range(count):
        rho_column = autocorrelation(column(k))[1 : horizon + 1]
        measured = float(rho_noise[1 : horizon + 1] @ rho_column)
        variance[k] = (1 + 2 * max(measured, float(modelled @ rho_column))) / n
    return np.clip(1.0 / np.maximum(variance, 1e-300), 3.0, float(n))


def shift_pvalue(residual: Array, column: Callable[[int], Array], count: int) -> float:
    """p-value that the residual is associated with any of a candidate's `count` columns (one per width,
    `column(k)` the k-th, read when needed: an hour's candidate held whole would be 100 MB).

    Each column's correlation gets a t-test on its effective sample size; the smallest p-value is
    Bonferroni-corrected over the columns.
    """
    e = residual - residual.mean()
    ee = max(float(e @ e), 1e-300)
    energy, r = np.empty(count), np.empty(count)
    for k in range(count):
        phi = _centred(column(k))
        energy[k] = max(float(phi @ phi), 1e-300)
        r[k] = float(phi @ e) / np.sqrt(energy[k] * ee)
    best = int(np.argmax(np.abs(r)))
    phi = _centred(column(best))
    noise = e - phi * (phi @ e) / energy[best]
    n_eff = effective_samples(noise, lambda k: _centred(column(k)), count)
    r = np.clip(r, -0.999999, 0.999999)
    t = np.abs(r) * np.sqrt((n_eff - 2) / (1 - r**2))
    return float(min(1.0, count * float(np.min(2 * stats.t.sf(t, n_eff - 2)))))


def _centred(x: Array) -> Array:
    return x - x.mean()


def t_pvalue(estimate: float, standard_error: float, dof: int) -> float:
    """Two-sided p-value of a coefficient given its (jackknife) standard error."""
    if standard_error <= 0:
        return 0.0 if estimate else 1.0
    return float(2 * stats.t.sf(abs(estimate) / standard_error, dof))


def correlation_length(residual: Array) -> int:
    """Samples until the residual's autocorrelation first drops below CORRELATED (bootstrap block length)."""
    below = np.flatnonzero(autocorrelation(residual) < CORRELATED)
    return int(below[0]) if below.size else len(residual)


def block_bootstrap_indices(n: int, block: int, rng: np.random.Generator) -> NDArray[np.int64]:
    """Indices of a circular block bootstrap sample: random blocks of consecutive samples, wrapped."""
    block = int(np.clip(block, 1, max(1, n // 4)))
    starts = rng.integers(0, n, size=-(-n // block))
    return ((starts[:, None] + np.arange(block)[None, :]).reshape(-1)[:n]) % n
