"""An hour of recording fits: the regressor bank, most of what a diagnosis holds per sample, is held once.

Each test measures the peak of traced memory at two lengths: what grows with the recording is the
difference (the Gram matrices and imports do not)."""

from __future__ import annotations

import tracemalloc
from collections.abc import Callable
from typing import Any

import numpy as np

from pegbt.physics import ArmPhysics
from pegbt.sim2real.crossval import BlockedGrams
from pegbt.sim2real.library import build_columns

SHORT, LONG = 3_000, 6_000


def _peak_bytes(action: Callable[[], Any]) -> tuple[int, Any]:
    tracemalloc.start()
    try:
        result = action()
        return tracemalloc.get_traced_memory()[1], result
    finally:
        tracemalloc.stop()


def _stream(n: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    rng = np.random.default_rng(0)
    t = 0.01 * np.arange(n)
    q_cmd = 0.3 * np.sin(np.outer(t, rng.uniform(0.2, 1.0, 6)) + rng.uniform(0, 6, 6))
    return q_cmd, t, ArmPhysics.load("ideal", "PSM1").static_map(q_cmd)


def test_the_bank_is_built_in_place():
    build_columns(*_stream(100))  # imports what the kernels use
    short_stream, long_stream = _stream(SHORT), _stream(LONG)
    short, (short_bank, _) = _peak_bytes(lambda: build_columns(*short_stream))
    long, (long_bank, _) = _peak_bytes(lambda: build_columns(*long_stream))
    # the bank and the transients of one kind's group of columns (about a third of it); never the bank twice
    assert long - short < 1.6 * (long_bank.nbytes - short_bank.nbytes)


def _add_three_columns(n: int) -> tuple[int, BlockedGrams, list[np.ndarray], np.ndarray]:
    rng = np.random.default_rng(1)
    bank = rng.normal(size=(n, 200))
    grams = BlockedGrams(bank, rng.normal(size=(n, 6)))
    added = [rng.normal(size=n) for _ in range(3)]
    peak, indices = _peak_bytes(lambda: [grams.add_column(column) for column in added])
    assert indices == [200, 201, 202]
    return peak, grams, added, bank


def test_added_columns_do_not_copy_the_bank():
    short, _, _, short_bank = _add_three_columns(SHORT)
    long, grams, added, bank = _add_three_columns(LONG)
    assert long - short < 0.2 * (bank.nbytes - short_bank.nbytes)
    np.testing.assert_array_equal(
        grams.column_values([3, 201, 0]), np.column_stack([bank[:, 3], added[1], bank[:, 0]])
    )
    whole = np.column_stack([bank, *added])
    block = slice(0, LONG // 20)  # the first of the 20 blocks
    np.testing.assert_allclose(grams.gram[0], whole[block].T @ whole[block], rtol=1e-12, atol=1e-9)
