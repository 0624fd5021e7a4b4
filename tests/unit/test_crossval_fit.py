"""A fit on some blocks of the blocked Gram matrices is least squares on those blocks' rows alone, whichever
few columns of the bank it fits and holds fixed (a jackknife leaves one block out at a time)."""

from __future__ import annotations

import numpy as np
import pytest

from pegbt.sim2real.crossval import BlockedGrams, block_edges


@pytest.mark.parametrize("m", [1, 12])  # a one-column bank, and a bank of which a few columns are fitted
def test_a_fit_on_some_blocks_is_least_squares_on_their_rows(m):
    rng = np.random.default_rng(4)
    n = 600
    bank = rng.normal(size=(n, m))
    targets = bank @ rng.normal(size=(m, 6)) + 0.1 * rng.normal(size=(n, 6))
    grams = BlockedGrams(bank, targets)
    edges = block_edges(n)
    blocks = np.ones(len(edges) - 1, dtype=bool)
    blocks[[3, 7]] = False
    rows = np.concatenate([np.arange(a, b) for a, b, kept in zip(edges[:-1], edges[1:], blocks) if kept])
    free, fixed = (np.array([m - 1]), np.zeros(0, int)) if m == 1 else (np.array([9, 2, 5]), np.array([7, 0]))
    target = targets[rows, 4] - bank[np.ix_(rows, fixed)].sum(1)
    expected = np.linalg.lstsq(bank[np.ix_(rows, free)], target, rcond=None)[0]
    np.testing.assert_allclose(grams.fit(4, free, fixed, blocks), expected, rtol=1e-6, atol=1e-9)
