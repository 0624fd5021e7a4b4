"""The dVRK's patient-side manipulators as every part names them: the arms and their six joints.

Joint order is yaw, pitch, insertion, roll, wrist pitch, wrist yaw. Recordings, model files and cable
effects call the joints `q1`..`q6` (`JOINT_NAMES`); messages about limits say what each joint does
(`JOINT_LABELS`).
"""

from __future__ import annotations

from os import PathLike

from pegbt.errors import PegbtError

ARMS = ("PSM1", "PSM2")
JOINT_NAMES = ("q1", "q2", "q3", "q4", "q5", "q6")
JOINT_LABELS = ("yaw", "pitch", "insertion", "roll", "wrist_pitch", "wrist_yaw")
N_JOINTS = len(JOINT_NAMES)


def known_arm(arm: object, where: str | PathLike[str] | None = None) -> str:
    """`arm` if it names a PSM, else a `PegbtError` (about file `where`, when given)."""
    if arm not in ARMS:
        raise PegbtError(f"unknown arm {arm!r}; expected one of {', '.join(ARMS)}", file=where, field="arm")
    return str(arm)


def joint_label(index: int) -> str:
    """`q3 (insertion)`: how messages name joint `index` (from 0)."""
    return f"q{index + 1} ({JOINT_LABELS[index]})"
