"""Blocked cross-validation of linear models over the regressor bank, from per-block Gram matrices.

The recording is cut into `N_BLOCKS` contiguous blocks; `N_FOLDS` folds each hold out a run of
consecutive blocks, so held-out data are a contiguous segment (neighbouring samples, correlated by
the noise, never sit on both sides of a fit). Each block keeps its Gram matrix MᵀM, MᵀY and YᵀY, so
a model on any column subset is fitted on the training blocks and scored on the held-out ones in
O(p³), independent of the recording's length: thousands of candidate fits cost milliseconds. The bank
itself is never held in memory: its rows come in chunks of at most `CHUNK_ROWS` (the kernels' state
carried across chunks, `pegbt.sim2real.library.Bank`), each summed into its block's Gram matrix and
spilled, column by column, to an unnamed temporary file, from which columns added later (widths refined
between grid values) are crossed with it and any column is read back. At 100 Hz the bank (223 columns)
is 1.8 kB a sample: an hour would be 640 MB, a day would not fit.
"""

from __future__ import annotations

import functools
import os
import tempfile
from collections.abc import Iterable, Iterator, Sequence
from typing import Protocol

import numpy as np
from numpy.typing import NDArray

from pegbt.scratch import scratch

Array = NDArray[np.float64]

N_BLOCKS = 20
N_FOLDS = 5
CHUNK_ROWS = 8192  # rows of the bank computed and summed at once: 15 MB of 223 columns
RIDGE = 1e-9  # relative to each column's energy: keeps near-collinear grids solvable, biases nothing visible


def block_edges(n: int, n_blocks: int = N_BLOCKS) -> NDArray[np.int64]:
    """Boundaries of `n_blocks` contiguous, nearly equal blocks of `n` samples (n_blocks + 1 indices).

    Cross-validation holds out whole blocks, not scattered samples: neighbouring samples of a recording are
    correlated, and a fold that shares them with training would overstate every effect's gain."""
    return np.linspace(0, n, n_blocks + 1).round().astype(np.int64)


def fold_ranges(n: int, n_blocks: int = N_BLOCKS, n_folds: int = N_FOLDS) -> list[tuple[int, int]]:
    """Sample ranges [start, stop) of each fold's held-out segment: `n_blocks // n_folds` consecutive blocks."""
    edges = block_edges(n, n_blocks)
    per_fold = n_blocks // n_folds
    return [(int(edges[f * per_fold]), int(edges[(f + 1) * per_fold])) for f in range(n_folds)]


class Columns(Protocol):
    """A column bank (n, m) given chunk by chunk: what `BlockedGrams` reads (an array is one too)."""

    @property
    def shape(self) -> tuple[int, ...]: ...

    def blocks(self, edges: Sequence[int]) -> Iterator[Array]:
        """The bank's rows edges[k]:edges[k+1], for each k in order."""
        ...


def chunk_edges(edges: NDArray[np.int64], rows: int | None = None) -> NDArray[np.int64]:
    """The block `edges` with each block cut into pieces of at most `rows` (`CHUNK_ROWS`) samples."""
    rows = CHUNK_ROWS if rows is None else rows
    cuts = [np.arange(a, b, rows) for a, b in zip(edges[:-1], edges[1:])]
    return np.concatenate([*cuts, edges[-1:]]).astype(np.int64)


class ColumnFile:
    """Columns of `n` samples in an unnamed temporary file, each stored whole (column-major), so one is
    read back in a single read and a chunk of rows in one read per column. The file goes when this does."""

    def __init__(self, n: int) -> None:
        self.n = n
        self._file = tempfile.TemporaryFile(prefix="pegbt-bank-", buffering=0)
        self._fd = self._file.fileno()

    def write(self, first: int, start: int, values: Array) -> None:
        """Store rows start:start+len(values) of columns first, first+1, … (values (c, k))."""
        for k in range(values.shape[1]):
            data = np.ascontiguousarray(values[:, k]).view(np.uint8)
            done = 0
            while done < data.size:
                done += os.pwrite(self._fd, data[done:].data, ((first + k) * self.n + start) * 8 + done)

    def read(self, column: int, start: int = 0, stop: int | None = None, out: Array | None = None) -> Array:
        """Rows start:stop of one column (into `out` when given)."""
        stop = self.n if stop is None else stop
        values = np.empty(stop - start) if out is None else out
        data = values.view(np.uint8)
        done = 0
        while done < data.size:
            got = os.preadv(self._fd, [data[done:].data], (column * self.n + start) * 8 + done)
            if got <= 0:
                raise OSError(f"the column file ended at column {column}, row {start + done // 8}")
            done += got
        return values

    def rows(self, count: int, start: int, stop: int) -> Array:
        """Rows start:stop of columns 0…count−1, as a C-ordered (stop − start, count) array."""
        rows = np.empty((stop - start, count))
        column = np.empty(stop - start)
        for k in range(count):
            rows[:, k] = self.read(k, start, stop, column)
        return rows


class BlockedGrams:
    """Per-block Gram matrices of a column bank M (N, m) and targets Y (N, J); `column_values` reads M."""

    def __init__(
        self, columns: Columns | Array, targets: Array, n_blocks: int = N_BLOCKS, n_folds: int = N_FOLDS
    ) -> None:
        n, m = columns.shape[:2]
        self.targets = targets
        self.edges = block_edges(n, n_blocks)
        self._chunks = chunk_edges(self.edges)
        self._block_of_chunk = np.searchsorted(self.edges, self._chunks[:-1], side="right") - 1
        self._store = ColumnFile(n)
        self._bank_width = m
        self._width = m  # columns in the store: the bank's, then those added
        self.gram = np.zeros((n_blocks, m, m))
        self.rhs = np.zeros((n_blocks, m, targets.shape[1]))
        self.yy = np.zeros((n_blocks, targets.shape[1]))
        blocks = (
            (columns[a:b] for a, b in zip(self._chunks[:-1], self._chunks[1:]))
            if isinstance(columns, np.ndarray)
            else columns.blocks(self._chunks.tolist())
        )
        for (a, b), block, rows in zip(self._pairs(), self._block_of_chunk, blocks):
            self.gram[block] += rows.T @ rows
            self.rhs[block] += rows.T @ targets[a:b]
            self.yy[block] += (targets[a:b] ** 2).sum(0)
            self._store.write(0, a, rows)
        self.fold_of_block = np.repeat(np.arange(n_folds), n_blocks // n_folds)
        self.n_folds = n_folds
        self._derive()

    def _pairs(self) -> list[tuple[int, int]]:
        return list(zip(self._chunks[:-1].tolist(), self._chunks[1:].tolist()))

    def _derive(self) -> None:
        """Fold and total sums of the per-block terms, and the column scales used in solves."""
        in_fold = [self.fold_of_block == f for f in range(self.n_folds)]
        self._fold_gram = np.stack([self.gram[mask].sum(0) for mask in in_fold])
        self._fold_rhs = np.stack([self.rhs[mask].sum(0) for mask in in_fold])
        self._fold_yy = np.stack([self.yy[mask].sum(0) for mask in in_fold])
        self.total_gram = self.gram.sum(0)
        self.total_rhs = self.rhs.sum(0)
        self._scale = np.sqrt(np.maximum(np.diag(self.total_gram), 1e-300))

    def add_column(self, column: Array) -> int:
        """Append a column (a width refined between grid values) to the bank; returns its index."""
        return self.add_columns([column])[0]

    def add_columns(self, columns: Iterable[Array]) -> list[int]:
        """Append columns to the bank, crossed with it in one pass over its rows; returns their indices.

        Each column is spilled to the store as it comes, before the next is asked for, and the pass reads
        them back a chunk at a time: given lazily, never more than one of them is held whole."""
        m = self._width
        k = 0
        for column in columns:
            self._store.write(m + k, 0, np.asarray(column, dtype=np.float64)[:, None])
            k += 1
        if not k:
            return []
        gram = np.zeros((len(self.gram), m + k, m + k))
        gram[:, :m, :m] = self.gram
        rhs = np.zeros((len(self.gram), m + k, self.targets.shape[1]))
        rhs[:, :m] = self.rhs
        for (a, b), block in zip(self._pairs(), self._block_of_chunk):
            rows = self._store.rows(self._bank_width, a, b)
            added = [self._store.read(j, a, b) for j in range(self._bank_width, m + k)]
            for i in range(k):
                column = added[m - self._bank_width + i]
                earlier = [previous @ column for previous in added[: m - self._bank_width + i]]
                cross = np.concatenate([rows.T @ column, earlier])
                gram[block, : m + i, m + i] += cross
                gram[block, m + i, : m + i] += cross
                gram[block, m + i, m + i] += column @ column
                rhs[block, m + i] += column @ self.targets[a:b]
        self.gram, self.rhs = gram, rhs
        self._width = m + k
        self._derive()
        return list(range(m, m + k))

    def column_values(self, columns: NDArray[np.int64] | list[int]) -> Array:
        """The values (N, k) of bank columns `columns`, in order, in scratch (`pegbt.scratch`):
        a model's dozen columns at once would be a hundred bytes a sample."""
        index = np.asarray(columns, dtype=np.int64).reshape(-1)
        values = scratch((self._store.n, len(index)))
        for k, column in enumerate(index.tolist()):
            values[:, k] = self._store.read(column)
        return values

    def fold_energy(self, column: int) -> Array:
        """Sum of squares of one column within each held-out fold (n_folds,)."""
        return self._fold_gram[:, column, column].copy()

    def fold_ranges(self) -> list[tuple[int, int]]:
        """Sample ranges [start, stop) of the held-out segment of each fold."""
        return fold_ranges(int(self.edges[-1]), len(self.edges) - 1, self.n_folds)

    def _solve(self, gram: Array, rhs: Array, cols: NDArray[np.int64]) -> Array:
        """Least-squares coefficients for (..., p, p) Grams and (..., p) right-hand sides, column-scaled."""
        s = self._scale[cols]
        g = gram / (s[..., :, None] * s[..., None, :]) + RIDGE * np.eye(cols.shape[-1])
        return np.linalg.solve(g, (rhs / s)[..., None])[..., 0] / s

    def _reduced(
        self, gram: Array, rhs: Array, yy: Array, free: NDArray[np.int64], fixed: NDArray[np.int64]
    ) -> tuple[Array, Array, Array]:
        """Gram terms of the target z = y − Σ fixed columns: (G[free, free], Mᵀz on free, zᵀz).

        `gram` (..., m, m), `rhs` (..., m), `yy` (...); `free` (C, p), `fixed` (C, q) → (..., C, ...).
        """
        g_ff = gram[..., free[:, :, None], free[:, None, :]]
        g_fp = gram[..., free[:, :, None], fixed[:, None, :]].sum(-1)
        g_pp = gram[..., fixed[:, :, None], fixed[:, None, :]].sum((-1, -2))
        b = rhs[..., free] - g_fp
        zz = yy[..., None] - 2 * rhs[..., fixed].sum(-1) + g_pp
        return g_ff, b, zz

    def fit(
        self,
        joint: int,
        free: NDArray[np.int64],
        fixed: NDArray[np.int64] | None = None,
        blocks: NDArray[np.bool_] | None = None,
    ) -> Array:
        """Coefficients of the `free` columns for target `joint` (the `fixed` ones at 1), on all or some blocks."""
        free = np.asarray(free, dtype=np.int64)
        fixed = np.zeros(0, dtype=np.int64) if fixed is None else np.asarray(fixed, dtype=np.int64)
        if blocks is None:
            gram, rhs, local = self.total_gram, self.total_rhs[:, joint], np.r_[free, fixed]
        else:
            gram, rhs, local = self._summed(blocks, joint, np.r_[free, fixed])
        g_ff, b, _ = self._reduced(
            gram, rhs, np.zeros(()), local[None, : len(free)], local[None, len(free) :]
        )
        return self._solve(g_ff, b, free[None])[0]

    def _summed(
        self, blocks: NDArray[np.bool_], joint: int, columns: NDArray[np.int64]
    ) -> tuple[Array, Array, NDArray[np.int64]]:
        """The Gram and right-hand side of target `joint` summed over `blocks`, only where `columns` meet
        (a jackknife fits a few columns of a bank of hundreds, once per block left out), with `columns`
        as indices into them. Summed block after block, the order NumPy sums the whole (blocks, m, m)
        stack in, so the figures are the same to the last bit; a one-column bank NumPy sums pairwise."""
        kept = np.flatnonzero(blocks)
        if self.gram.shape[1] == 1 or kept.size == 0:
            return self.gram[blocks].sum(0), self.rhs[blocks].sum(0)[:, joint], columns
        used, local = np.unique(columns, return_inverse=True)
        gram = functools.reduce(np.add, self.gram[np.ix_(kept, used, used)])
        rhs = functools.reduce(np.add, self.rhs[np.ix_(kept, used, np.array([joint]))])[:, 0]
        return gram, rhs, local.astype(np.int64)

    def cv_sse(self, joint: int, free: NDArray[np.int64], fixed: NDArray[np.int64] | None = None) -> Array:
        """Held-out sum of squared errors per fold (n_folds,) of one model."""
        fixed = np.zeros((1, 0), dtype=np.int64) if fixed is None else np.asarray(fixed, dtype=np.int64)[None]
        return self.cv_sse_many(joint, np.asarray(free, dtype=np.int64)[None], fixed)[0]

    def cv_sse_many(
        self, joint: int, free: NDArray[np.int64], fixed: NDArray[np.int64] | None = None
    ) -> Array:
        """Held-out SSE per fold (C, n_folds) for C models: `free` (C, p) fitted columns, `fixed` (C, q)
        columns entering with coefficient 1 (backlash, lag, delay are physically unit-gain)."""
        free = np.asarray(free, dtype=np.int64).reshape(len(free), -1)
        fixed = (
            np.zeros((len(free), 0), dtype=np.int64) if fixed is None else np.asarray(fixed, dtype=np.int64)
        )
        g_fold, b_fold, zz_fold = self._reduced(
            self._fold_gram, self._fold_rhs[:, :, joint], self._fold_yy[:, joint], free, fixed
        )  # (F, C, p, p), (F, C, p), (F, C)
        if free.shape[1] == 0:
            return zz_fold.T
        g_train = g_fold.sum(0)[None] - g_fold
        b_train = b_fold.sum(0)[None] - b_fold
        beta = self._solve(g_train, b_train, free[None])
        sse = (
            zz_fold
            - 2 * np.einsum("fcp,fcp->fc", beta, b_fold)
            + np.einsum("fcp,fcpq,fcq->fc", beta, g_fold, beta)
        )
        return sse.T

    def blocks_jackknife(
        self, joint: int, free: NDArray[np.int64], index: int, fixed: NDArray[np.int64] | None = None
    ) -> tuple[float, float]:
        """Coefficient `index` of a model and its delete-one-block jackknife standard error."""
        full = self.fit(joint, free, fixed)[index]
        blocks = np.ones(len(self.gram), dtype=bool)
        leave_out = []
        for k in range(len(self.gram)):
            blocks[k] = False
            leave_out.append(self.fit(joint, free, fixed, blocks)[index])
            blocks[k] = True
        values = np.array(leave_out)
        n = len(values)
        return float(full), float(np.sqrt((n - 1) / n * ((values - values.mean()) ** 2).sum()))
