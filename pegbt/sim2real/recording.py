"""Recordings of commanded versus measured joints: reading, validating, writing.

Two layouts are read: a dVRK dataset folder (`q_cmd.npy`, `q_phy.npy`, optional `t_stamp.npy`, as in
`../shared/data/dvrk/`) and a CSV with columns `t,q1_cmd..q6_cmd,q1_meas..q6_meas`. Everything a user can
get wrong (lengths, NaN rows, time running backwards, commands that never move, too few samples, a
file that is not a recording at all) is refused with a `PegbtError` naming the file and the problem,
before any analysis runs, so nothing that looks like a result is ever written for bad input.

Samples are either a stream (the controller's 100 Hz set-points, where lag and delay act between
samples) or settled set-points seconds apart (the arm came to rest before each sample, as in the dVRK
recordings). `Recording.sampling` says which, and why.
"""

from __future__ import annotations

import csv
import math
from dataclasses import dataclass
from pathlib import Path

import numpy as np
from numpy.typing import NDArray

from pegbt.errors import PegbtError
from pegbt.physics import JOINT_NAMES

Array = NDArray[np.float64]

N_JOINTS = len(JOINT_NAMES)
MIN_SAMPLES = 50
# Samples closer than this are a stream (the dVRK controller runs at 100 Hz); farther apart, the arm had
# time to settle between them, so lag and delay are over before each sample.
STREAM_MAX_INTERVAL_S = 0.1
CSV_COLUMNS = ("t", *(f"{q}_cmd" for q in JOINT_NAMES), *(f"{q}_meas" for q in JOINT_NAMES))


@dataclass(frozen=True)
class Sampling:
    """How the samples relate in time: `stream` or `setpoints`, and the reason it was assumed."""

    mode: str
    reason: str

    @property
    def is_stream(self) -> bool:
        return self.mode == "stream"


@dataclass(frozen=True)
class Recording:
    """Commanded and measured joints (N, 6) of one arm, with sample times when known."""

    path: Path
    q_cmd: Array
    q_phy: Array
    t: Array | None

    @property
    def n(self) -> int:
        return len(self.q_cmd)

    @property
    def times(self) -> Array:
        """Sample times in seconds, or sample indices when the recording has no timestamps."""
        return np.arange(self.n, dtype=float) if self.t is None else self.t

    @property
    def sampling(self) -> Sampling:
        if self.t is None:
            return Sampling("setpoints", "no timestamps: each sample is taken as a settled set-point")
        interval = float(np.median(np.diff(self.t)))
        if interval <= STREAM_MAX_INTERVAL_S:
            return Sampling("stream", f"median sample interval {interval * 1e3:.1f} ms: a command stream")
        return Sampling(
            "setpoints",
            f"median sample interval {interval:.2f} s > {STREAM_MAX_INTERVAL_S} s: settled set-points "
            "(lag and delay have died out before each sample)",
        )

    def slice(self, start: int, stop: int) -> "Recording":
        """The samples [start, stop) as a recording of their own."""
        t = None if self.t is None else self.t[start:stop]
        return Recording(self.path, self.q_cmd[start:stop], self.q_phy[start:stop], t)


def load_recording(path: str | Path) -> Recording:
    """Read and validate a recording folder or CSV; a `PegbtError` naming the file and problem if bad."""
    path = Path(path)
    if not path.exists():
        raise PegbtError("no such recording (expected a folder with q_cmd.npy and q_phy.npy, or a CSV)", file=path)
    if path.is_dir():
        q_cmd, q_phy, t = _read_folder(path)
        where = path
    elif path.suffix.lower() == ".csv":
        q_cmd, q_phy, t = _read_csv(path)
        where = path
    else:
        raise PegbtError("not a recording: expected a folder with q_cmd.npy and q_phy.npy, or a .csv file", file=path)
    validate(q_cmd, q_phy, t, where)
    return Recording(path, q_cmd, q_phy, t)


def _load_npy(path: Path) -> Array:
    try:
        data = np.load(path, allow_pickle=False)
    except (OSError, ValueError, EOFError) as error:
        raise PegbtError(f"not a recording: cannot read it as a NumPy array ({error})", file=path) from None
    if not np.issubdtype(data.dtype, np.number):
        raise PegbtError(f"not a recording: holds {data.dtype} values, not numbers", file=path)
    return np.asarray(data, dtype=float)


def _read_folder(folder: Path) -> tuple[Array, Array, Array | None]:
    missing = [name for name in ("q_cmd.npy", "q_phy.npy") if not (folder / name).is_file()]
    if missing:
        raise PegbtError(f"not a recording: the folder lacks {' and '.join(missing)}", file=folder)
    q_cmd = _load_npy(folder / "q_cmd.npy")
    q_phy = _load_npy(folder / "q_phy.npy")
    t = _load_npy(folder / "t_stamp.npy").reshape(-1) if (folder / "t_stamp.npy").is_file() else None
    return q_cmd, q_phy, t


def _read_csv(path: Path) -> tuple[Array, Array, Array]:
    try:
        with path.open(newline="") as handle:
            rows = list(csv.reader(handle))
    except (OSError, UnicodeDecodeError) as error:
        raise PegbtError(f"not a recording: cannot read it as text ({error})", file=path) from None
    if not rows:
        raise PegbtError("not a recording: the file is empty", file=path)
    header = [name.strip() for name in rows[0]]
    absent = [name for name in CSV_COLUMNS if name not in header]
    if absent:
        raise PegbtError(
            f"not a recording: the header lacks {', '.join(absent)} (expected {','.join(CSV_COLUMNS)})",
            file=path, line=1, field=absent[0],
        )
    columns = [header.index(name) for name in CSV_COLUMNS]
    values = np.empty((len(rows) - 1, len(CSV_COLUMNS)))
    for line, row in enumerate(rows[1:], start=2):
        for k, column in enumerate(columns):
            text = row[column].strip() if column < len(row) else ""
            try:
                values[line - 2, k] = float(text) if text else math.nan
            except ValueError:
                raise PegbtError(f"not a number: {text!r}", file=path, line=line, column=column + 1,
                                 field=CSV_COLUMNS[k]) from None
    return values[:, 1:7], values[:, 7:13], values[:, 0]


def validate(q_cmd: Array, q_phy: Array, t: Array | None, where: Path) -> None:
    """Refuse recordings that cannot be analysed, saying what is wrong with them."""
    for name, array in (("q_cmd", q_cmd), ("q_phy", q_phy)):
        if array.ndim != 2 or array.shape[1] != N_JOINTS:
            raise PegbtError(f"expected an N×{N_JOINTS} array of joints, got shape {array.shape}", file=where, field=name)
    if len(q_cmd) != len(q_phy):
        raise PegbtError(f"different lengths: {len(q_cmd)} commanded samples but {len(q_phy)} measured", file=where)
    if t is not None and len(t) != len(q_cmd):
        raise PegbtError(f"different lengths: {len(t)} timestamps for {len(q_cmd)} samples", file=where, field="t")
    if len(q_cmd) < MIN_SAMPLES:
        raise PegbtError(f"only {len(q_cmd)} sample(s): at least {MIN_SAMPLES} are needed", file=where)
    for name, array in (("q_cmd", q_cmd), ("q_phy", q_phy), ("t", t)):
        if array is None:
            continue
        bad = np.flatnonzero(~np.isfinite(array.reshape(len(array), -1)).all(axis=1))
        if bad.size:
            more = f" and {bad.size - 1} more" if bad.size > 1 else ""
            raise PegbtError(f"NaN or infinite value in sample {bad[0]}{more}", file=where, line=_line(where, bad[0]),
                             field=name)
    if t is not None:
        steps = np.diff(t)
        if (steps <= 0).any():
            n = int(np.flatnonzero(steps <= 0)[0]) + 1
            raise PegbtError(f"timestamps not increasing at sample {n} ({t[n]:.6g} s after {t[n - 1]:.6g} s)",
                             file=where, line=_line(where, n), field="t")
    if np.ptp(q_cmd, axis=0).max() == 0:
        raise PegbtError("constant commands: no joint's command ever changes, so nothing can be identified",
                         file=where, field="q_cmd")


def _line(where: Path, sample: int) -> int | None:
    """The CSV line of a sample (header is line 1); None for array folders."""
    return sample + 2 if where.suffix.lower() == ".csv" else None


def write_recording(folder: str | Path, q_cmd: Array, q_phy: Array, t: Array | None) -> Path:
    """Write a recording in the dVRK folder layout."""
    folder = Path(folder)
    folder.mkdir(parents=True, exist_ok=True)
    np.save(folder / "q_cmd.npy", np.asarray(q_cmd, dtype=float))
    np.save(folder / "q_phy.npy", np.asarray(q_phy, dtype=float))
    if t is not None:
        np.save(folder / "t_stamp.npy", np.asarray(t, dtype=float))
    return folder
