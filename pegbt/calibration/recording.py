"""Recordings of commanded versus physical joints, in the dVRK dataset layout.

A recording is a folder with `q_cmd.npy` (N×6 commanded joints), `q_phy.npy` (N×6 physical joints) and
optionally `t_stamp.npy` (N seconds) and `meta.json` (which arm). The real recordings in
`../shared/data/dvrk/` have no `meta.json`; their folder names end in the arm (`..._PSM1`), so that is
where the arm is read from. `RecordingWriter` writes the same layout, for `pegbt calibrate collect`.
"""

from __future__ import annotations

import json
import re
from dataclasses import dataclass
from datetime import datetime, timezone
from pathlib import Path

import numpy as np
from numpy.typing import ArrayLike, NDArray

from pegbt.errors import PegbtError
from pegbt.physics import JOINT_NAMES

N_JOINTS = len(JOINT_NAMES)
ARMS = ("PSM1", "PSM2")
_ARM_IN_NAME = re.compile(r"(PSM[12])$")


@dataclass(frozen=True)
class Recording:
    """Commanded and physical joints of one arm, sample by sample; `path` names it in messages."""

    q_cmd: NDArray[np.float64]
    q_phy: NDArray[np.float64]
    t_stamp: NDArray[np.float64] | None
    path: Path
    arm: str | None = None

    def __len__(self) -> int:
        return len(self.q_cmd)

    def head(self, fraction: float) -> int:
        """Number of samples in the first `fraction` of the recording (the training part of a split)."""
        if not 0.0 < fraction <= 1.0:
            raise PegbtError(f"the training fraction must be in (0, 1], got {fraction}", field="fraction")
        return int(round(fraction * len(self)))

    def slice(self, start: int, stop: int | None = None) -> "Recording":
        """Samples [start, stop) as a recording of their own."""
        t = None if self.t_stamp is None else self.t_stamp[start:stop]
        return Recording(self.q_cmd[start:stop], self.q_phy[start:stop], t, self.path, self.arm)


def _load_array(path: Path, name: str) -> NDArray[np.float64]:
    try:
        return np.asarray(np.load(path / name, allow_pickle=False), dtype=float)
    except FileNotFoundError:
        raise PegbtError(f"not a recording: {name} is missing", file=path) from None
    except (OSError, ValueError) as error:
        raise PegbtError(f"cannot read {name}: {error}", file=path / name) from None


def _arm_of(path: Path) -> str | None:
    meta = path / "meta.json"
    if meta.exists():
        try:
            arm = json.loads(meta.read_text()).get("arm")
        except (OSError, json.JSONDecodeError, AttributeError) as error:
            raise PegbtError(f"cannot read recording metadata: {error}", file=meta) from None
        if arm not in ARMS:
            raise PegbtError(f"unknown arm {arm!r}; expected one of {', '.join(ARMS)}", file=meta, field="arm")
        return arm
    match = _ARM_IN_NAME.search(path.resolve().name)
    return match.group(1) if match else None


def load_recording(path: str | Path) -> Recording:
    """Read and check a recording folder; a `PegbtError` naming the file says what is wrong."""
    path = Path(path)
    if not path.is_dir():
        raise PegbtError("not a recording folder (expected q_cmd.npy and q_phy.npy inside)", file=path)
    q_cmd, q_phy = _load_array(path, "q_cmd.npy"), _load_array(path, "q_phy.npy")
    t_stamp = _load_array(path, "t_stamp.npy") if (path / "t_stamp.npy").exists() else None
    for name, array in (("q_cmd.npy", q_cmd), ("q_phy.npy", q_phy)):
        if array.ndim != 2 or array.shape[1] != N_JOINTS:
            raise PegbtError(
                f"expected N×{N_JOINTS} joints ({', '.join(JOINT_NAMES)}), got shape {array.shape}", file=path / name
            )
    if len(q_cmd) != len(q_phy) or (t_stamp is not None and t_stamp.shape != (len(q_cmd),)):
        shapes = f"q_cmd {q_cmd.shape}, q_phy {q_phy.shape}" + ("" if t_stamp is None else f", t_stamp {t_stamp.shape}")
        raise PegbtError(f"the arrays differ in length: {shapes}", file=path)
    for name, array in (("q_cmd.npy", q_cmd), ("q_phy.npy", q_phy), ("t_stamp.npy", t_stamp)):
        if array is not None and not np.all(np.isfinite(array)):
            row = int(np.argwhere(~np.isfinite(array))[0][0])
            raise PegbtError(f"non-finite value (NaN or inf) in sample {row}", file=path / name, line=row + 1)
    return Recording(q_cmd, q_phy, t_stamp, path, _arm_of(path))


def check_trainable(recording: Recording, joints: tuple[int, ...], min_samples: int) -> None:
    """Refuse a recording a model cannot learn from: too few samples, or a learned joint that never moves."""
    if len(recording) < min_samples:
        raise PegbtError(
            f"too few samples to train on: {len(recording)}, need at least {min_samples}", file=recording.path
        )
    for j in joints:
        span = float(np.ptp(recording.q_cmd[:, j]))
        if span < 1e-3:
            raise PegbtError(
                f"{JOINT_NAMES[j]} never moves in the commands (range {span:.2g}): its cable effects cannot be learned",
                file=recording.path / "q_cmd.npy",
                field=JOINT_NAMES[j],
            )


def check_arm(recording: Recording, arm: str, what: str) -> None:
    """Refuse to mix arms: a recording of PSM2 says nothing about PSM1's cables."""
    if recording.arm is not None and recording.arm != arm:
        raise PegbtError(f"the recording is of {recording.arm}, but {what} is for {arm}", file=recording.path, field="arm")


class RecordingWriter:
    """Collects (command, physical joints, time) samples and writes them in the dataset layout.

    Samples are appended as they are measured (a settled set-point or a 100 Hz stream); `close()` writes
    the arrays and `meta.json` at once, so a folder never holds a half-written recording.
    """

    def __init__(self, path: str | Path, arm: str) -> None:
        if arm not in ARMS:
            raise PegbtError(f"unknown arm {arm!r}; expected one of {', '.join(ARMS)}", field="arm")
        self.path = Path(path)
        self.arm = arm
        self._rows: list[tuple[NDArray[np.float64], NDArray[np.float64], float]] = []

    def add(self, q_cmd: ArrayLike, q_phy: ArrayLike, t: float) -> None:
        """Append one sample; refuses non-finite joints and time that does not increase."""
        q_cmd, q_phy = np.asarray(q_cmd, dtype=float), np.asarray(q_phy, dtype=float)
        if q_cmd.shape != (N_JOINTS,) or q_phy.shape != (N_JOINTS,):
            raise PegbtError(f"a sample needs {N_JOINTS} commanded and {N_JOINTS} physical joints", file=self.path)
        if not (np.all(np.isfinite(q_cmd)) and np.all(np.isfinite(q_phy)) and np.isfinite(t)):
            raise PegbtError(f"non-finite sample {len(self._rows)}", file=self.path)
        if self._rows and t <= self._rows[-1][2]:
            raise PegbtError(f"time must increase: sample {len(self._rows)} at {t} s", file=self.path, field="t_stamp")
        self._rows.append((q_cmd, q_phy, float(t)))

    def __len__(self) -> int:
        return len(self._rows)

    def close(self) -> Path:
        """Write the recording folder and return its path."""
        if not self._rows:
            raise PegbtError("no samples recorded", file=self.path)
        self.path.mkdir(parents=True, exist_ok=True)
        np.save(self.path / "q_cmd.npy", np.stack([row[0] for row in self._rows]))
        np.save(self.path / "q_phy.npy", np.stack([row[1] for row in self._rows]))
        np.save(self.path / "t_stamp.npy", np.array([row[2] for row in self._rows]))
        meta = {"arm": self.arm, "joints": list(JOINT_NAMES), "samples": len(self._rows),
                "written": datetime.now(timezone.utc).isoformat(timespec="seconds")}
        (self.path / "meta.json").write_text(json.dumps(meta, indent=2) + "\n")
        return self.path
