"""Whether a recording's joints are an arm's: commands a robot could have been sent, physical joints that
follow them, in radians and metres.

Why a check of its own: a recording in degrees, millimetres or ×100, or a `q_phy` of pure noise, is
finite and well shaped, so the format checks pass it, and the fit then names effects and writes a
model of nothing (a held-out tip error of metres). Commands are judged by the robot's own limits (the
dVRK's, `DVRK_LIMITS`, or its `share/` folder's), never by the planner's narrower `skills/psm.yaml`,
with `COMMAND_TOLERANCE` past them: the reference paper's dVRK 1.x took an insertion of 0.2412 m where
dVRK 2.x stops at 0.24 m. Physical samples no arm could reach are measurement faults
(`pegbt.physics.faults`), which the diagnosis reports and leaves out; only a recording most of whose
physical samples are such is not an arm's.
"""

from __future__ import annotations

from collections.abc import Callable
from pathlib import Path

import numpy as np
from numpy.typing import NDArray

from pegbt.errors import PegbtError
from pegbt.motion.robot_config import RobotLimits
from pegbt.physics.faults import PHYSICAL_TOLERANCE, Errors, outlying, unreachable
from pegbt.psm import N_JOINTS, joint_label
from pegbt.scratch import ROWS, scratch, scratch_where

# How far a recorded command may pass the robot's limits: rad for rotary joints, m for insertion (5 mm
# covers dVRK 1.x's 0.2412 m; a recording in millimetres is off by a factor of 1000).
COMMAND_TOLERANCE = np.array([0.05, 0.05, 0.005, 0.05, 0.05, 0.05])
# A joint whose commands move must follow them: the arm joints (q1-q3) closely, the cable-driven wrist
# (offsets, coupling, hysteresis) at least loosely. Noise does not correlate with anything.
MIN_CORRELATION = np.array([0.9, 0.9, 0.9, 0.3, 0.3, 0.3])
# Spread of commands under which a joint is taken as not moved (below the tracker's resolution).
MOVED = np.array([0.01, 0.01, 0.0005, 0.01, 0.01, 0.01])
# The share of physical samples that may lie where no arm could be: past it, the recording's bulk is not an
# arm's (physical joints in other units, or of another arm), not a tracker that lost the tool for a while.
MAX_UNREACHABLE_SHARE = 0.5


def check_arm_joints(
    q_cmd: NDArray[np.float64],
    q_phy: NDArray[np.float64],
    limits: RobotLimits,
    file_of: Callable[[str], Path],
    line_of: Callable[[int], int | None],
) -> None:
    """A `PegbtError` naming the file, joint and sample where the recording stops being an arm's.
    Physical samples no arm could reach are not refused unless they are most of the recording."""
    _within(
        q_cmd,
        limits.lower - COMMAND_TOLERANCE,
        limits.upper + COMMAND_TOLERANCE,
        "q_cmd",
        "the robot's joint limits widened by the command tolerance (0.05 rad, 5 mm)",
        file_of,
        line_of,
    )
    errors = Errors.of(q_cmd, q_phy)
    for joint in range(N_JOINTS):
        own = ~outlying(errors, joint)  # a tracker that lost the tool does not make the joint unfollowing
        command, physical = scratch_where(q_cmd[:, joint], own), scratch_where(q_phy[:, joint], own)
        if command.size < 2 or np.ptp(command) < MOVED[joint] or np.ptp(physical) == 0:
            continue
        correlation = _correlation(command, physical)
        if not correlation >= MIN_CORRELATION[joint]:
            raise PegbtError(
                f"{joint_label(joint)} does not follow its commands (correlation {correlation:.2f}, an arm's "
                f"is at least {MIN_CORRELATION[joint]:g}): not a recording of an arm, or the columns are mixed up",
                file=file_of("q_phy"),
                field=f"q_phy.{joint_label(joint).split()[0]}",
            )
    first: tuple[int, int] | None = None
    count = 0
    for a in range(0, len(q_cmd), ROWS):
        beyond = unreachable(q_cmd[a : a + ROWS], q_phy[a : a + ROWS], limits)
        rows = beyond.any(axis=1)
        count += int(rows.sum())
        if first is None and rows.any():
            sample, joint = (int(i) for i in np.argwhere(beyond)[0])
            first = (a + sample, joint)
    share = count / len(q_cmd)
    if share > MAX_UNREACHABLE_SHARE:
        assert first is not None, "a share above one half has a first sample"
        sample, joint = first
        unit = "m" if joint == 2 else "rad"
        raise PegbtError(
            f"{joint_label(joint)} is {q_phy[sample, joint]:.6g} {unit} at sample {sample} (commanded "
            f"{q_cmd[sample, joint]:.6g}), and {100 * share:.0f} % of the samples lie where no arm could be: "
            f"beyond the robot's joint limits [{limits.lower[joint]:.4g}, {limits.upper[joint]:.4g}] {unit} "
            f"widened by the physical tolerance ({PHYSICAL_TOLERANCE[joint]:g} {unit}), or farther from the "
            "command than its controller allows; joints are in rad and m (not degrees, millimetres or scaled)",
            file=file_of("q_phy"),
            line=line_of(sample),
            field=f"q_phy.{joint_label(joint).split()[0]}",
        )


def _correlation(x: NDArray[np.float64], y: NDArray[np.float64]) -> float:
    """`np.corrcoef(x, y)[0, 1]` with its centred copy in scratch (`pegbt.scratch`), not in memory."""
    centred = scratch((2, len(x)))
    centred[0], centred[1] = x, y
    centred -= centred.mean(axis=1)[:, None]
    c = np.dot(centred, centred.T) / (len(x) - 1)
    return float(np.clip(c[0, 1] / np.sqrt(c[0, 0]) / np.sqrt(c[1, 1]), -1.0, 1.0))


def _within(
    q: NDArray[np.float64],
    lower: NDArray[np.float64],
    upper: NDArray[np.float64],
    name: str,
    bound: str,
    file_of: Callable[[str], Path],
    line_of: Callable[[int], int | None],
) -> None:
    first: tuple[int, int] | None = None
    count = 0
    for a in range(0, len(q), ROWS):  # a chunk at a time: the comparisons are bytes a sample each
        outside = (q[a : a + ROWS] < lower) | (q[a : a + ROWS] > upper)
        count += int(outside.any(axis=1).sum())
        if first is None and outside.any():
            sample, joint = (int(i) for i in np.argwhere(outside)[0])
            first = (a + sample, joint)
    if first is None:
        return
    sample, joint = first
    unit = "m" if joint == 2 else "rad"
    raise PegbtError(
        f"{joint_label(joint)} is {q[sample, joint]:.6g} {unit} at sample {sample}, outside {bound} "
        f"[{lower[joint]:.4g}, {upper[joint]:.4g}] {unit} ({count} sample(s) outside); joints are in rad and "
        "m (not degrees, millimetres or scaled)",
        file=file_of(name),
        line=line_of(sample),
        field=f"{name}.{joint_label(joint).split()[0]}",
    )


# Timestamps are seconds: wall-clock (about 1.7e9 today) or from the start. Steps under a microsecond
# (a denormal, say) are no sampling any controller does, and make rates and intervals overflow.
MAX_TIME = 1e10  # s
MIN_STEP = 1e-6  # s


def check_times(t: NDArray[np.float64], file: Path, line_of: Callable[[int], int | None]) -> None:
    """A `PegbtError` unless the (increasing) timestamps are seconds of a plausible size and step."""
    sample = first_where(len(t), lambda a, b: np.abs(t[a:b]) > MAX_TIME)
    if sample is not None:
        raise PegbtError(
            f"timestamp {t[sample]:.6g} s at sample {sample} is beyond ±{MAX_TIME:g} s: not seconds",
            file=file,
            line=line_of(sample),
            field="t",
        )
    step = first_where(len(t) - 1, lambda a, b: np.diff(t[a : b + 1]) < MIN_STEP)
    if step is not None:
        sample = step + 1
        raise PegbtError(
            f"timestamps {t[sample] - t[sample - 1]:.3g} s apart at sample {sample}: samples must be at "
            f"least {MIN_STEP:g} s apart",
            file=file,
            line=line_of(sample),
            field="t",
        )


def first_where(n: int, test: Callable[[int, int], NDArray[np.bool_]]) -> int | None:
    """The first of `n` indices where `test(a, b)` (a mask of rows [a, b), found `ROWS` at a time, so a
    long recording's comparisons are never held whole) is true anywhere in its row, or None."""
    for a in range(0, n, ROWS):
        hits = test(a, min(a + ROWS, n))
        rows = np.flatnonzero(hits.reshape(len(hits), -1).any(axis=1))
        if rows.size:
            return a + int(rows[0])
    return None
