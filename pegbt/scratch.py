"""Recording-sized arrays backed by unnamed temporary files instead of the process's own memory.

A diagnosis keeps a few arrays as long as the recording (its held-out predictions, the base replay and
the residual, each nested training part's copy; a recording decoded from a bag or cast from float32):
at 100 Hz each N × 6 one is 48 bytes a sample, 4 GB a day together. Mapped from a file the kernel may
write their pages out and drop them, so what the process itself holds stays bounded by its chunks
whatever the length; the figures are the same, since the values are the same float64s.
"""

from __future__ import annotations

import tempfile
from collections.abc import Sequence

import numpy as np
from numpy.typing import NDArray

Array = NDArray[np.float64]


def scratch(shape: tuple[int, ...]) -> Array:
    """An uninitialised float64 array of `shape` mapped from an unnamed temporary file, which goes when
    the array does (an empty one is an ordinary array: nothing to map)."""
    if int(np.prod(shape)) == 0:
        return np.empty(shape)
    with tempfile.TemporaryFile(prefix="pegbt-scratch-") as handle:
        return np.memmap(handle, dtype=np.float64, mode="w+", shape=shape)


def scratch_rows(values: Array, segment: tuple[int, int]) -> Array:
    """A scratch copy of `values` without rows `segment` [a, b): the rows before it and after it, in
    order (what `values[mask]` gives, without the copy in memory)."""
    a, b = segment
    out = scratch((len(values) - (b - a), *values.shape[1:]))
    out[:a] = values[:a]
    out[a:] = values[b:]
    return out


ROWS = 8192  # rows copied at a time: what a copy holds in memory beside its source and its scratch


def scratch_copy(values: NDArray[np.floating]) -> Array:
    """`values` as float64 in scratch, cast a chunk of rows at a time (a single number stays one)."""
    if values.ndim == 0:
        return np.asarray(values, dtype=np.float64)
    out = scratch(values.shape)
    for a in range(0, len(values), ROWS):
        out[a : a + ROWS] = values[a : a + ROWS]
    return out


def scratch_where(values: Array, keep: NDArray[np.bool_]) -> Array:
    """`values[keep]` (rows where `keep` is true) in scratch, gathered a chunk of rows at a time."""
    out = scratch((int(np.count_nonzero(keep)), *values.shape[1:]))
    written = 0
    for a in range(0, len(values), ROWS):
        rows = values[a : a + ROWS][keep[a : a + ROWS]]
        out[written : written + len(rows)] = rows
        written += len(rows)
    return out


class ScratchRows:
    """Rows of `width` float64s appended one at a time (a decoder's, whose count is known only at the
    end), gathered `ROWS` at a time and written to an unnamed temporary file, mapped once done: a list of
    them would hold a Python float object per number."""

    def __init__(self, width: int) -> None:
        self._file = tempfile.TemporaryFile(prefix="pegbt-scratch-")
        self._buffer = np.empty((ROWS, width))
        self._filled = 0
        self.count = 0

    def append(self, row: Sequence[float] | Array) -> None:
        self._buffer[self._filled] = row
        self._filled += 1
        self.count += 1
        if self._filled == ROWS:
            self._spill()

    def _spill(self) -> None:
        self._buffer[: self._filled].tofile(self._file)
        self._filled = 0

    def array(self) -> Array:
        """The rows appended so far, (count, width), mapped from the file."""
        self._spill()
        self._file.flush()
        if self.count == 0:
            return np.empty((0, self._buffer.shape[1]))
        return np.memmap(self._file, dtype=np.float64, mode="r+", shape=(self.count, self._buffer.shape[1]))
