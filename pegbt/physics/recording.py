"""Recordings of commanded versus physical joints: reading, validating, writing (the dVRK dataset layout).

The one reader and writer of the data the arm-physics model is fitted to, shared by the sim-to-real
tool (which names the effects) and calibration (which learns and inverts them). Two layouts are read:

- a folder with `q_cmd.npy` (N×6 commanded joints), `q_phy.npy` (N×6 physical joints), optional
  `t_stamp.npy` (N seconds) and optional `meta.json` (`{"arm": "PSM1", ...}`), as in
  `../shared/data/dvrk/`; those real folders have no `meta.json`, their names end in the arm (`..._PSM1`);
- a CSV with columns `t,q1_cmd..q6_cmd,q1_meas..q6_meas`;
- a ROS 2 bag (an MCAP file or a rosbag2 folder) with command and physical joint-state topics, paired by
  stamp (`bagfile.py`).

Everything a user can get wrong (lengths, NaN rows, time running backwards, commands that never move,
too few samples, a file that is not a recording at all) is refused with a `PegbtError` naming the file,
the field and the sample, before any analysis runs, so nothing that looks like a result is written.
Commands are judged by the robot's own limits (`--robot-config`, else the dVRK's), not the planner's;
physical samples no arm could reach are measurement faults for the analysis, not a reason to refuse.

Samples are either a stream (the controller's 100 Hz set-points, where lag and delay act between
samples) or settled set-points seconds apart (the arm came to rest before each sample, as in the dVRK
recordings). `Recording.sampling` says which, and why. `RecordingWriter` collects samples as they are
measured (`pegbt calibrate collect`) and writes the folder at once.
"""

from __future__ import annotations

import csv
import io
import json
import math
import os
import re
import sys
from dataclasses import dataclass, replace
from datetime import UTC, datetime
from pathlib import Path

import numpy as np
from numpy.typing import ArrayLike, NDArray

from pegbt.boundedio import map_npy, read_bytes
from pegbt.errors import PegbtError
from pegbt.motion.robot_config import DEFAULT_TOOL, DVRK_LIMITS, RobotLimits, robot_limits
from pegbt.physics.bagfile import is_bag, read_bag
from pegbt.physics.plausible import check_arm_joints, check_times, first_where
from pegbt.psm import JOINT_NAMES, N_JOINTS, known_arm
from pegbt.scratch import ROWS, scratch_copy, scratch_where

Array = NDArray[np.float64]

MIN_SAMPLES = 50
# Samples closer than this are a stream (the dVRK controller runs at 100 Hz); farther apart, the arm had
# time to settle between them, so lag and delay are over before each sample.
STREAM_MAX_INTERVAL_S = 0.1
CSV_COLUMNS = ("t", *(f"{q}_cmd" for q in JOINT_NAMES), *(f"{q}_meas" for q in JOINT_NAMES))
DVRK_DATA_VARIABLE = "PEGBT_DVRK_DATA"
FILES = {"q_cmd": "q_cmd.npy", "q_phy": "q_phy.npy", "t": "t_stamp.npy"}
_ARM_AT_END = re.compile(r"(PSM[12])$")
MAX_ARRAY_BYTES = 256 * 2**20  # per .npy file: 5.6 million samples of six joints, 15 hours at 100 Hz
MAX_CSV_BYTES = 512 * 2**20
MAX_META_BYTES = 64 * 2**10


class RecordingError(PegbtError):
    """A file that is not a readable recording of an arm, named with its field and sample."""


def dvrk_data_dir(required: bool = False) -> Path:
    """The folder of real dVRK recordings: `$PEGBT_DVRK_DATA`, else `shared/data/dvrk` beside the checkout.
    With `required`, a `PegbtError` when the recordings are not there."""
    folder = Path(
        os.environ.get(DVRK_DATA_VARIABLE, Path(__file__).resolve().parents[3] / "shared" / "data" / "dvrk")
    )
    if required and not (folder / "random_smooth_grey1_PSM1" / "q_cmd.npy").exists():
        raise PegbtError(f"real dVRK recordings not found (set {DVRK_DATA_VARIABLE})", file=folder)
    return folder


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
    """Commanded and physical joints (N, 6) of one arm, with sample times when known; `path` names it in
    messages, `arm` is None when neither `meta.json` nor the name says which arm it is; `resolution`
    (per joint, in the joints' units) is what the measurement can tell apart, when `meta.json` says;
    `limits` are the robot's it was judged by, which its measurement faults are found against."""

    path: Path
    q_cmd: Array
    q_phy: Array
    t: Array | None = None
    arm: str | None = None
    resolution: tuple[float, ...] | None = None
    limits: RobotLimits = DVRK_LIMITS
    notes: tuple[str, ...] = ()  # damage the reader read past (a bag cut short), for the reports to say

    @property
    def n(self) -> int:
        return len(self.q_cmd)

    def __len__(self) -> int:
        return self.n

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

    def warn(self) -> None:
        """Say on stderr, one line each, the damage the reader read past (`pegbt: warning: FILE: ...`)."""
        for note in self.notes:
            print(f"pegbt: warning: {self.path}: {note}", file=sys.stderr)

    def head(self, fraction: float) -> int:
        """Number of samples in the first `fraction` of the recording (the training part of a split)."""
        if not 0.0 < fraction <= 1.0:
            raise PegbtError(f"a share of the recording must be in (0, 1], got {fraction}", field="fraction")
        return int(round(fraction * self.n))

    def subset(self, keep: NDArray[np.bool_]) -> Recording:
        """The samples where `keep` is true, as a recording of their own in scratch (itself if it keeps
        all)."""
        if keep.all():
            return self
        t = None if self.t is None else scratch_where(self.t, keep)
        return replace(
            self, q_cmd=scratch_where(self.q_cmd, keep), q_phy=scratch_where(self.q_phy, keep), t=t
        )

    def slice(self, start: int, stop: int | None = None) -> Recording:
        """The samples [start, stop) as a recording of their own."""
        t = None if self.t is None else self.t[start:stop]
        return replace(self, q_cmd=self.q_cmd[start:stop], q_phy=self.q_phy[start:stop], t=t)


# ---------------------------------------------------------------------------------------------- reading
def load_recording(
    path: str | Path,
    *,
    cmd: str | None = None,
    phy: str | None = None,
    arm: str | None = None,
    settled: float | None = None,
    min_samples: int = MIN_SAMPLES,
    robot_config: str | Path | None = None,
    robot_tool: str | None = None,
) -> Recording:
    """Read and validate a recording folder, CSV or bag; a `RecordingError` naming the file and problem if
    bad. `cmd`, `phy`, `arm` and `settled` choose a bag's topics and samples (`bagfile.read_bag`);
    `min_samples` is what the analysis needs (a refit of a model's offsets needs fewer than a fit);
    `robot_config` (a dVRK `share/` folder) and `robot_tool` give the robot's limits (default the dVRK's)."""
    try:
        limits = robot_limits(robot_config, robot_tool or DEFAULT_TOOL)
        return _load_recording(
            Path(path), cmd=cmd, phy=phy, arm=arm, settled=settled, min_samples=min_samples, limits=limits
        )
    except RecordingError:
        raise
    except PegbtError as error:
        raise RecordingError(
            error.message, file=error.file, line=error.line, column=error.column, field=error.field
        ) from None


def _load_recording(
    path: Path,
    *,
    cmd: str | None,
    phy: str | None,
    arm: str | None,
    settled: float | None,
    min_samples: int,
    limits: RobotLimits,
) -> Recording:
    try:
        exists = path.exists()
    except (OSError, ValueError) as error:
        raise PegbtError(f"cannot read the recording: {error}", file=path) from None
    if not exists:
        raise PegbtError(
            "no such recording (expected a folder with q_cmd.npy and q_phy.npy, a CSV, an MCAP file or a "
            "rosbag2 folder)",
            file=path,
        )
    if is_bag(path):
        samples = read_bag(path, cmd=cmd, phy=phy, arm=arm, settled=settled)
        validate(samples.q_cmd, samples.q_phy, samples.t, path, limits=limits, min_samples=min_samples)
        return Recording(
            path, samples.q_cmd, samples.q_phy, samples.t, samples.arm, limits=limits, notes=samples.notes
        )
    if cmd or phy or settled is not None:
        raise PegbtError(
            "--cmd, --phy and --settled choose a bag's topics; this recording is not a bag", file=path
        )
    if path.is_dir():
        q_cmd, q_phy, t = _read_folder(path)
    elif path.suffix.lower() == ".csv":
        q_cmd, q_phy, t = _read_csv(path)
    else:
        raise PegbtError(
            "not a recording: expected a folder with q_cmd.npy and q_phy.npy, a .csv or a .mcap file",
            file=path,
        )
    arm = _arm_of(path)
    validate(q_cmd, q_phy, t, path, limits=limits, min_samples=min_samples)
    return Recording(path, q_cmd, q_phy, t, arm, _resolution_of(path), limits)


def _load_npy(path: Path) -> Array:
    """The array mapped from its private copy (`map_npy`: the file may change under a diagnosis), or,
    not in float64 as this machine orders it, cast into scratch (`pegbt.scratch`): never a recording's
    length in the process's own memory."""
    try:
        values = map_npy(path, MAX_ARRAY_BYTES)
    except PegbtError as error:
        raise PegbtError(f"not a recording: {error.message}", file=path) from None
    return np.asarray(values, dtype=np.float64) if values.dtype == np.float64 else scratch_copy(values)


def _read_folder(folder: Path) -> tuple[Array, Array, Array | None]:
    missing = [FILES[name] for name in ("q_cmd", "q_phy") if not (folder / FILES[name]).is_file()]
    if missing:
        raise PegbtError(f"not a recording: the folder lacks {' and '.join(missing)}", file=folder)
    q_cmd = _load_npy(folder / FILES["q_cmd"])
    q_phy = _load_npy(folder / FILES["q_phy"])
    t = _load_npy(folder / FILES["t"]).reshape(-1) if (folder / FILES["t"]).is_file() else None
    return q_cmd, q_phy, t


def _read_csv(path: Path) -> tuple[Array, Array, Array]:
    raw = read_bytes(path, MAX_CSV_BYTES, "CSV recording")
    try:
        rows = list(csv.reader(io.StringIO(raw.decode("utf-8"), newline="")))
    except (UnicodeDecodeError, csv.Error) as error:
        raise PegbtError(f"not a recording: cannot read it as CSV text ({error})", file=path) from None
    if not rows:
        raise PegbtError("not a recording: the file is empty", file=path)
    header = [name.strip() for name in rows[0]]
    absent = [name for name in CSV_COLUMNS if name not in header]
    if absent:
        raise PegbtError(
            f"not a recording: the header lacks {', '.join(absent)} (expected {','.join(CSV_COLUMNS)})",
            file=path,
            line=1,
            field=absent[0],
        )
    columns = [header.index(name) for name in CSV_COLUMNS]
    values = np.empty((len(rows) - 1, len(CSV_COLUMNS)))
    for line, row in enumerate(rows[1:], start=2):
        for k, column in enumerate(columns):
            text = row[column].strip() if column < len(row) else ""
            try:
                values[line - 2, k] = float(text) if text else math.nan
            except ValueError:
                raise PegbtError(
                    f"not a number: {text!r}", file=path, line=line, column=column + 1, field=CSV_COLUMNS[k]
                ) from None
    return values[:, 1:7], values[:, 7:13], values[:, 0]


def _meta(path: Path) -> dict | None:
    """A folder's `meta.json`, if it has one."""
    meta = path / "meta.json"
    if not (path.is_dir() and meta.exists()):
        return None
    try:
        data = json.loads(read_bytes(meta, MAX_META_BYTES, "metadata file").decode("utf-8"))
    except (UnicodeDecodeError, json.JSONDecodeError, RecursionError) as error:
        reason = "nested too deeply" if isinstance(error, RecursionError) else str(error)
        raise PegbtError(f"cannot read recording metadata: {reason}", file=meta) from None
    if not isinstance(data, dict):
        raise PegbtError("recording metadata must be an object", file=meta)
    return data


def _resolution_of(path: Path) -> tuple[float, ...] | None:
    """Per-joint measurement resolution from `meta.json` (`"resolution": [six values]`), if it says."""
    meta = _meta(path)
    if meta is None or "resolution" not in meta:
        return None
    return parse_resolution(meta["resolution"], path / "meta.json")


def parse_resolution(values: object, where: Path | str | None = None) -> tuple[float, ...]:
    """Six non-negative finite numbers, one per joint, from a list or a comma-separated string."""
    items = values.split(",") if isinstance(values, str) else values
    try:
        numbers = tuple(float(v) for v in items) if isinstance(items, (list, tuple)) else ()
    except (TypeError, ValueError):
        numbers = ()
    if len(numbers) != N_JOINTS or not all(np.isfinite(numbers)) or min(numbers) < 0:
        raise PegbtError(
            f"resolution is {N_JOINTS} non-negative numbers, one per joint in its units; got {values!r}",
            file=where,
            field="resolution",
        )
    return numbers


def _arm_of(path: Path) -> str | None:
    """The arm from `meta.json` in a folder, else from the name's ending (`random_smooth_grey1_PSM1`)."""
    meta = _meta(path)
    if meta is not None and "arm" in meta:
        return known_arm(meta["arm"], path / "meta.json")
    name = path.resolve().name if path.is_dir() else path.resolve().stem
    match = _ARM_AT_END.search(name)
    return match.group(1) if match else None


# ---------------------------------------------------------------------------------------------- validation
def validate(
    q_cmd: Array,
    q_phy: Array,
    t: Array | None,
    where: Path,
    *,
    limits: RobotLimits = DVRK_LIMITS,
    min_samples: int = MIN_SAMPLES,
) -> None:
    """Refuse recordings that cannot be analysed or are not an arm's (`pegbt.physics.plausible`, by the
    robot's `limits`), saying which file, field and sample is wrong."""
    array: Array | None  # the joints, then also the times, which a recording may lack
    for name, array in (("q_cmd", q_cmd), ("q_phy", q_phy)):
        if array.ndim != 2 or array.shape[1] != N_JOINTS:
            raise PegbtError(
                f"expected an N×{N_JOINTS} array of joints ({', '.join(JOINT_NAMES)}), got shape "
                f"{array.shape}",
                file=_file(where, name),
                field=name,
            )
    if len(q_cmd) != len(q_phy):
        raise PegbtError(
            f"different lengths: {len(q_cmd)} commanded samples but {len(q_phy)} measured", file=where
        )
    if t is not None and len(t) != len(q_cmd):
        raise PegbtError(
            f"different lengths: {len(t)} timestamps for {len(q_cmd)} samples", file=where, field="t"
        )
    if len(q_cmd) < min_samples:
        raise PegbtError(f"only {len(q_cmd)} sample(s): at least {min_samples} are needed", file=where)
    for name, array in (("q_cmd", q_cmd), ("q_phy", q_phy), ("t", t)):
        if array is None:
            continue
        first = first_where(len(array), lambda a, b: _nonfinite_rows(array, a, b))
        if first is not None:
            n = len(array)
            bad = sum(int(_nonfinite_rows(array, a, min(a + ROWS, n)).sum()) for a in range(first, n, ROWS))
            more = f" and {bad - 1} more" if bad > 1 else ""
            raise PegbtError(
                f"NaN or infinite value in sample {first}{more}",
                file=_file(where, name),
                line=_line(where, first),
                field=name,
            )
    if t is not None:
        step = first_where(len(t) - 1, lambda a, b: np.diff(t[a : b + 1]) <= 0)
        if step is not None:
            n = step + 1
            raise PegbtError(
                f"timestamps not increasing at sample {n} ({t[n]:.6g} s after {t[n - 1]:.6g} s)",
                file=_file(where, "t"),
                line=_line(where, n),
                field="t",
            )
    if np.ptp(q_cmd, axis=0).max() == 0:
        raise PegbtError(
            "constant commands: no joint's command ever changes, so nothing can be identified",
            file=_file(where, "q_cmd"),
            field="q_cmd",
        )
    if t is not None:
        check_times(t, _file(where, "t"), lambda sample: _line(where, sample))
    check_arm_joints(
        q_cmd, q_phy, limits, lambda name: _file(where, name), lambda sample: _line(where, sample)
    )


def _nonfinite_rows(array: Array, a: int, b: int) -> NDArray[np.bool_]:
    """Which of rows [a, b) hold a NaN or an infinity."""
    return np.asarray(~np.isfinite(array[a:b].reshape(b - a, -1)).all(axis=1), dtype=bool)


def _is_csv(where: Path) -> bool:
    return where.suffix.lower() == ".csv"


def _file(where: Path, name: str) -> Path:
    """The file holding array `name`: the CSV itself, or the folder's .npy file."""
    return where if _is_csv(where) or not where.is_dir() or is_bag(where) else where / FILES[name]


def _line(where: Path, sample: int) -> int | None:
    """The CSV line of a sample (header is line 1); None for array folders (a sample is a row, not a line)."""
    return sample + 2 if _is_csv(where) else None


# ---------------------------------------------------------------------------------------------- writing
def write_recording(
    folder: str | Path,
    q_cmd: ArrayLike,
    q_phy: ArrayLike,
    t: ArrayLike | None,
    arm: str | None = None,
    resolution: tuple[float, ...] | None = None,
) -> Path:
    """Write a recording in the dVRK folder layout; with `arm` or `resolution`, also `meta.json` saying
    which arm it is and what its measurement resolves."""
    folder = Path(folder)
    folder.mkdir(parents=True, exist_ok=True)
    q_cmd = np.asarray(q_cmd, dtype=float)
    np.save(folder / FILES["q_cmd"], q_cmd)
    np.save(folder / FILES["q_phy"], np.asarray(q_phy, dtype=float))
    if t is not None:
        np.save(folder / FILES["t"], np.asarray(t, dtype=float))
    if arm is not None or resolution is not None:
        meta: dict[str, object] = {"arm": known_arm(arm)} if arm is not None else {}
        meta |= {
            "joints": list(JOINT_NAMES),
            "samples": len(q_cmd),
            "written": datetime.now(UTC).isoformat(timespec="seconds"),
        }
        if resolution is not None:
            meta["resolution"] = list(parse_resolution(resolution))
        (folder / "meta.json").write_text(json.dumps(meta, indent=2) + "\n")
    return folder


class RecordingWriter:
    """Collects (command, physical joints, time) samples as they are measured and writes them in the
    dataset layout; `close()` writes every file at once, so a folder never holds a half-written recording."""

    def __init__(self, path: str | Path, arm: str, min_samples: int = MIN_SAMPLES) -> None:
        self.path = Path(path)
        self.arm = known_arm(arm)
        self.min_samples = min_samples
        self._rows: list[tuple[Array, Array, float]] = []

    def add(self, q_cmd: ArrayLike, q_phy: ArrayLike, t: float) -> None:
        """Append one sample; refuses non-finite joints and time that does not increase."""
        q_cmd, q_phy = np.asarray(q_cmd, dtype=float), np.asarray(q_phy, dtype=float)
        if q_cmd.shape != (N_JOINTS,) or q_phy.shape != (N_JOINTS,):
            raise PegbtError(
                f"a sample needs {N_JOINTS} commanded and {N_JOINTS} physical joints", file=self.path
            )
        if not (np.all(np.isfinite(q_cmd)) and np.all(np.isfinite(q_phy)) and np.isfinite(t)):
            raise PegbtError(f"non-finite sample {len(self._rows)}", file=self.path)
        if self._rows and t <= self._rows[-1][2]:
            raise PegbtError(
                f"time must increase: sample {len(self._rows)} at {t} s", file=self.path, field="t"
            )
        self._rows.append((q_cmd, q_phy, float(t)))

    def __len__(self) -> int:
        return len(self._rows)

    def close(self) -> Path:
        """Write the recording folder (checked as `load_recording` checks it) and return its path."""
        if not self._rows:
            raise PegbtError("no samples recorded", file=self.path)
        q_cmd = np.stack([row[0] for row in self._rows])
        q_phy = np.stack([row[1] for row in self._rows])
        t = np.array([row[2] for row in self._rows])
        validate(q_cmd, q_phy, t, self.path, min_samples=self.min_samples)
        return write_recording(self.path, q_cmd, q_phy, t, self.arm)
