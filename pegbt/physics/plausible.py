"""Whether a recording's joints are an arm's: commands within its limits, physical joints near them and
following the commands, in radians and metres.

Why a check of its own: a recording in degrees, millimetres or ×100, or a `q_phy` of pure noise, is
finite and well shaped, so the format checks pass it, and the fit then names effects and writes a
model of nothing (a held-out tip error of metres). The limits are the arm's (`skills/psm.yaml`, the
same the simulator enforces); physical joints may pass them by a stated tolerance, since a real wrist
does: the four dVRK recordings' physical joints differ from their commands by up to 0.45 rad (q6).
"""

from __future__ import annotations

from collections.abc import Callable
from pathlib import Path

import numpy as np
from numpy.typing import NDArray

from pegbt.errors import PegbtError
from pegbt.motion.limits import arm_settings
from pegbt.psm import N_JOINTS, joint_label

# How far physical joints may lie beyond the commanded limits: rad for rotary joints, m for insertion.
PHYSICAL_TOLERANCE = np.array([0.5, 0.5, 0.01, 0.5, 0.5, 0.5])
# A joint whose commands move must follow them: the arm joints (q1-q3) closely, the cable-driven wrist
# (offsets, coupling, hysteresis) at least loosely. Noise does not correlate with anything.
MIN_CORRELATION = np.array([0.9, 0.9, 0.9, 0.3, 0.3, 0.3])
# Spread of commands under which a joint is taken as not moved (below the tracker's resolution).
MOVED = np.array([0.01, 0.01, 0.0005, 0.01, 0.01, 0.01])
COMMAND_SLACK = 1e-6  # rounding of a limit written with four decimals


def check_arm_joints(
    q_cmd: NDArray[np.float64],
    q_phy: NDArray[np.float64],
    arm: str | None,
    file_of: Callable[[str], Path],
    line_of: Callable[[int], int | None],
) -> None:
    """A `PegbtError` naming the file, joint and sample where the recording stops being an arm's.

    `arm` None uses PSM1's limits (both PSMs share them in skills/psm.yaml)."""
    settings = arm_settings(arm or "PSM1")
    lower, upper = settings.lower, settings.upper
    _within(
        q_cmd,
        lower - COMMAND_SLACK,
        upper + COMMAND_SLACK,
        "q_cmd",
        "the arm's joint limits",
        file_of,
        line_of,
    )
    _within(
        q_phy,
        lower - PHYSICAL_TOLERANCE,
        upper + PHYSICAL_TOLERANCE,
        "q_phy",
        "the arm's joint limits widened by the physical tolerance (0.5 rad, 0.01 m)",
        file_of,
        line_of,
    )
    for joint in range(N_JOINTS):
        command, physical = q_cmd[:, joint], q_phy[:, joint]
        if np.ptp(command) < MOVED[joint] or np.ptp(physical) == 0:
            continue
        correlation = float(np.corrcoef(command, physical)[0, 1])
        if not correlation >= MIN_CORRELATION[joint]:
            raise PegbtError(
                f"{joint_label(joint)} does not follow its commands (correlation {correlation:.2f}, an arm's "
                f"is at least {MIN_CORRELATION[joint]:g}): not a recording of an arm, or the columns are mixed up",
                file=file_of("q_phy"),
                field=f"q_phy.{joint_label(joint).split()[0]}",
            )


def _within(
    q: NDArray[np.float64],
    lower: NDArray[np.float64],
    upper: NDArray[np.float64],
    name: str,
    bound: str,
    file_of: Callable[[str], Path],
    line_of: Callable[[int], int | None],
) -> None:
    outside = (q < lower) | (q > upper)
    if not outside.any():
        return
    sample, joint = (int(i) for i in np.argwhere(outside)[0])
    count = int(outside.any(axis=1).sum())
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
    beyond = np.flatnonzero(np.abs(t) > MAX_TIME)
    if beyond.size:
        sample = int(beyond[0])
        raise PegbtError(
            f"timestamp {t[sample]:.6g} s at sample {sample} is beyond ±{MAX_TIME:g} s: not seconds",
            file=file,
            line=line_of(sample),
            field="t",
        )
    short = np.flatnonzero(np.diff(t) < MIN_STEP)
    if short.size:
        sample = int(short[0]) + 1
        raise PegbtError(
            f"timestamps {t[sample] - t[sample - 1]:.3g} s apart at sample {sample}: samples must be at "
            f"least {MIN_STEP:g} s apart",
            file=file,
            line=line_of(sample),
            field="t",
        )
