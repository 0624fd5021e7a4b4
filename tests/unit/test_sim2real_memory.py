"""Memory bounded whatever the recording's length: the regressor bank is computed a chunk of rows at a
time, the kernels' state carried across chunks, and spilled to a file; only its Gram matrices stay.

Each memory test measures the peak of traced memory at two lengths: what grows with the recording is the
difference (the Gram matrices and imports do not). The chunks are made small so that a few thousand
samples hold several of them per block."""

from __future__ import annotations

from typing import Any

import numpy as np
import pytest
from memory_helpers import peak_bytes

from pegbt.physics import ArmPhysics
from pegbt.physics.kernels import delay_blocks, delay_series, lag_blocks, lag_series, play_blocks, play_grid
from pegbt.sim2real import crossval
from pegbt.sim2real.crossval import BlockedGrams, block_edges
from pegbt.sim2real.library import build_columns
from pegbt.sim2real.significance import shift_pvalue

SHORT, LONG = 2_000, 4_000
CHUNK = 50  # rows: two chunks a block at SHORT, four at LONG


@pytest.fixture(autouse=True)
def small_chunks(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setattr(crossval, "CHUNK_ROWS", CHUNK)


def _stream(n: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    rng = np.random.default_rng(0)
    t = 0.01 * np.arange(n)
    q_cmd = 0.3 * np.sin(np.outer(t, rng.uniform(0.2, 1.0, 6)) + rng.uniform(0, 6, 6))
    return q_cmd, t, ArmPhysics.load("ideal", "PSM1").static_map(q_cmd)


def _targets(n: int) -> np.ndarray:
    return np.random.default_rng(2).normal(size=(n, 6))


def _whole(bank: Any) -> np.ndarray:
    """The bank computed in one piece (one chunk of every row)."""
    return next(bank.blocks([0, bank.shape[0]]))


def test_kernels_by_blocks_equal_the_whole_sequence():
    rng = np.random.default_rng(3)
    t = np.cumsum(rng.uniform(0.005, 0.015, 2_000))
    uniform = 0.01 * np.arange(2_000)
    u = np.cumsum(rng.normal(size=2_000)) * 0.01
    edges = [0, 1, 7, 500, 1_333, 2_000]
    widths = np.array([1e-3, 0.01, 0.1])
    np.testing.assert_array_equal(np.vstack(list(play_blocks(u, widths, edges))), play_grid(u, widths))
    for times in (t, uniform):
        np.testing.assert_array_equal(
            np.concatenate(list(lag_blocks(u, times, 0.05, edges))), lag_series(u, times, 0.05)
        )
        np.testing.assert_array_equal(
            np.concatenate(list(delay_blocks(u, times, 0.03, edges))), delay_series(u, times, 0.03)
        )


def test_grams_by_chunks_equal_the_whole_bank():
    q_cmd, t, drivers = _stream(SHORT)
    bank, _ = build_columns(q_cmd, t, drivers)
    targets = _targets(SHORT)
    grams = BlockedGrams(bank, targets)
    whole = _whole(bank)
    for k, (a, b) in enumerate(zip(block_edges(SHORT)[:-1], block_edges(SHORT)[1:])):
        np.testing.assert_allclose(grams.gram[k], whole[a:b].T @ whole[a:b], rtol=1e-12, atol=1e-12)
        np.testing.assert_allclose(grams.rhs[k], whole[a:b].T @ targets[a:b], rtol=1e-12, atol=1e-12)
    np.testing.assert_array_equal(grams.column_values([5, 0, 100]), whole[:, [5, 0, 100]])


def _grams_peak(n: int) -> tuple[int, int]:
    q_cmd, t, drivers = _stream(n)
    targets = _targets(n)
    peak, grams = peak_bytes(lambda: BlockedGrams(build_columns(q_cmd, t, drivers)[0], targets))
    return peak, grams.gram.shape[1] * 8 * n  # the bank's bytes, were it held


def test_the_bank_is_never_held():
    _grams_peak(300)  # imports what the kernels use
    short, short_bank = _grams_peak(SHORT)
    long, long_bank = _grams_peak(LONG)
    # the commands' copies (a percentile, a comparison) grow with the recording; the bank (223 columns) must not
    assert long - short < 0.05 * (long_bank - short_bank)


def _add_three_columns(n: int) -> tuple[int, BlockedGrams, list[np.ndarray], Any]:
    q_cmd, t, drivers = _stream(n)
    bank, _ = build_columns(q_cmd, t, drivers)
    grams = BlockedGrams(bank, _targets(n))
    m = grams.gram.shape[1]
    rng = np.random.default_rng(1)
    added = [rng.normal(size=n) for _ in range(3)]
    peak, indices = peak_bytes(lambda: [grams.add_column(added[0]), *grams.add_columns(added[1:])])
    assert indices == [m, m + 1, m + 2]
    return peak, grams, added, bank


def test_added_columns_do_not_load_the_bank():
    short, *_ = _add_three_columns(SHORT)
    long, grams, added, bank = _add_three_columns(LONG)
    m = bank.shape[1]
    assert long - short < 0.05 * m * 8 * (LONG - SHORT)
    whole = np.column_stack([_whole(bank), *added])
    np.testing.assert_array_equal(
        grams.column_values([3, m + 1, 0]), np.column_stack([whole[:, 3], added[1], whole[:, 0]])
    )
    block = slice(0, LONG // 20)  # the first of the 20 blocks
    np.testing.assert_allclose(grams.gram[0], whole[block].T @ whole[block], rtol=1e-12, atol=1e-9)


def _pvalue_peak(n: int) -> tuple[int, float]:
    """Peak traced bytes of the p-value of a 12-width candidate over `n` samples of a bank's file."""
    q_cmd, t, drivers = _stream(n)
    bank, candidates = build_columns(q_cmd, t, drivers)
    grams = BlockedGrams(bank, _targets(n))
    candidate = next(c for c in candidates if c.kind == "lag" and c.joint == 2)
    column = grams.column_values(candidate.columns[4:5])[:, 0]
    residual = column + 0.1 * column.std() * grams.targets[:, 2]
    return peak_bytes(
        lambda: shift_pvalue(
            residual,
            lambda k: grams.column_values(candidate.columns[k : k + 1])[:, 0],
            len(candidate.columns),
        )
    )


def test_a_candidates_p_value_reads_its_columns_one_at_a_time():
    _pvalue_peak(300)
    short, _ = _pvalue_peak(SHORT)
    long, pvalue = _pvalue_peak(LONG)
    # per sample: a few columns' worth (the residual, the noise, one column and its FFT), not the twelve
    # columns centred and transformed together (70 of them at once)
    assert long - short < 12 * 8 * (LONG - SHORT)
    assert pvalue < 1e-6  # the residual holds one of the candidate's columns
