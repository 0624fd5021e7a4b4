"""Blocked cross-validation of linear models over the regressor bank, from per-block Gram matrices.

The recording is cut into `N_BLOCKS` contiguous blocks; `N_FOLDS` folds each hold out a run of
consecutive blocks, so held-out data are a contiguous segment (neighbouring samples, correlated by
the noise, never sit on both sides of a fit). Each block keeps its Gram matrix MᵀM, MᵀY and YᵀY, so
a model on any column subset is fitted on the training blocks and scored on the held-out ones in
O(p³), independent of the recording's length: thousands of candidate fits cost milliseconds. The bank
itself is kept once (columns added later, widths refined between grid values, are kept beside it, not
copied into a grown bank), since at 100 Hz it is most of what an hour of recording takes in memory.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

Array = NDArray[np.float64]

N_BLOCKS = 20
N_FOLDS = 5
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


class BlockedGrams:
    """Per-block Gram matrices of a column bank M (N, m) and targets Y (N, J); `column_values` reads M."""

    def __init__(
        self, columns: Array, targets: Array, n_blocks: int = N_BLOCKS, n_folds: int = N_FOLDS
    ) -> None:
        self._bank = columns
        self._added: list[Array] = []  # columns appended after the bank, in order
        self.targets = targets
        self.edges = block_edges(len(columns), n_blocks)
        pairs = list(zip(self.edges[:-1], self.edges[1:]))
        self.gram = np.stack([columns[a:b].T @ columns[a:b] for a, b in pairs])
        self.rhs = np.stack([columns[a:b].T @ targets[a:b] for a, b in pairs])
        self.yy = np.stack([(targets[a:b] ** 2).sum(0) for a, b in pairs])
        self.fold_of_block = np.repeat(np.arange(n_folds), n_blocks // n_folds)
        self.n_folds = n_folds
        self._derive()

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
        pairs = list(zip(self.edges[:-1], self.edges[1:]))
        m = self.gram.shape[1]
        cross = np.stack(
            [
                np.concatenate(
                    [self._bank[a:b].T @ column[a:b], [added[a:b] @ column[a:b] for added in self._added]]
                )
                for a, b in pairs
            ]
        )  # (B, m)
        gram = np.empty((len(pairs), m + 1, m + 1))
        gram[:, :m, :m] = self.gram
        gram[:, :m, m] = gram[:, m, :m] = cross
        gram[:, m, m] = [column[a:b] @ column[a:b] for a, b in pairs]
        self.gram = gram
        self.rhs = np.concatenate(
            [self.rhs, np.stack([column[a:b] @ self.targets[a:b] for a, b in pairs])[:, None]], 1
        )
        self._added.append(np.asarray(column, dtype=np.float64))
        self._derive()
        return m

    def column_values(self, columns: NDArray[np.int64] | list[int]) -> Array:
        """The values (N, k) of bank columns `columns`, in order."""
        index = np.asarray(columns, dtype=np.int64)
        m = self._bank.shape[1]
        if np.all(index < m):
            return self._bank[:, index]
        return np.stack([self._bank[:, i] if i < m else self._added[i - m] for i in index], axis=1)

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
        free = np.asarray(free, dtype=np.int64)[None]
        fixed = np.zeros((1, 0), dtype=np.int64) if fixed is None else np.asarray(fixed, dtype=np.int64)[None]
        gram = self.total_gram if blocks is None else self.gram[blocks].sum(0)
        rhs = (self.total_rhs if blocks is None else self.rhs[blocks].sum(0))[:, joint]
        g_ff, b, _ = self._reduced(gram, rhs, np.zeros(()), free, fixed)
        return self._solve(g_ff, b, free)[0]

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
