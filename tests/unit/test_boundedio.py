"""A `.npy` array read through `map_npy` is a private copy of the file as it was: a file truncated or
rewritten in place while it is copied is a `PegbtError` naming it, never numbers from two versions of it
(a diagnosis mapping the file itself died of SIGBUS when it was truncated:
`tests/integration/test_recording_changed.py`)."""

from __future__ import annotations

import os
from pathlib import Path

import numpy as np
import pytest

from pegbt import boundedio
from pegbt.boundedio import map_npy
from pegbt.errors import PegbtError

LIMIT = 2**20


def _saved(tmp_path: Path, rows: int = 1000) -> tuple[Path, np.ndarray]:
    """An (rows, 6) float64 array saved to a file whose modification time is long past, so that a write
    while it is read changes it whatever the file system's clock granularity."""
    values = np.random.default_rng(0).standard_normal((rows, 6))
    path = tmp_path / "q_phy.npy"
    np.save(path, values)
    os.utime(path, ns=(10**18, 10**18))
    return path, values


def _changing(monkeypatch: pytest.MonkeyPatch, path: Path, change) -> None:
    """Reads 4 kB at a time, and `change(path)` after the first."""
    real = os.preadv
    calls = []

    def preadv(fd: int, buffers: list, offset: int) -> int:
        got = real(fd, buffers, offset)
        calls.append(got)
        if len(calls) == 1:
            change(path)
        return got

    monkeypatch.setattr(boundedio, "COPY_BYTES", 4096)
    monkeypatch.setattr(os, "preadv", preadv)


def _truncate(path: Path) -> None:
    os.truncate(path, 1000)


def _rewrite_in_place(path: Path) -> None:
    with open(path, "r+b") as handle:
        handle.seek(8000)
        handle.write(np.zeros(100).tobytes())


@pytest.mark.parametrize("change", [_truncate, _rewrite_in_place])
def test_a_file_changed_while_it_is_copied_is_an_error_naming_it(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, change
) -> None:
    path, _ = _saved(tmp_path)
    _changing(monkeypatch, path, change)
    with pytest.raises(PegbtError, match="changed while it was read") as raised:
        map_npy(path, LIMIT)
    assert raised.value.file == str(path)


def test_the_array_is_the_file_as_it_was_read_whatever_happens_to_it_after(tmp_path: Path) -> None:
    path, values = _saved(tmp_path)
    read = map_npy(path, LIMIT)
    _rewrite_in_place(path)  # a mapping of the file itself would show the zeros
    np.testing.assert_array_equal(read, values)


def test_an_array_copied_in_many_reads_is_the_saved_one(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    monkeypatch.setattr(boundedio, "COPY_BYTES", 4093)  # chunks that end inside a number
    path, values = _saved(tmp_path)
    np.testing.assert_array_equal(map_npy(path, LIMIT), values)


def test_no_room_for_the_copy_is_an_error_naming_the_file(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    path, _ = _saved(tmp_path)
    full = tmp_path / "full"
    full.symlink_to("/dev/full")  # every write fails with ENOSPC

    def temporary_file(prefix: str) -> object:
        return open(full, "wb")

    monkeypatch.setattr(boundedio.tempfile, "TemporaryFile", temporary_file)
    with pytest.raises(PegbtError, match="no room for its private copy") as raised:
        map_npy(path, LIMIT)
    assert raised.value.file == str(path)
