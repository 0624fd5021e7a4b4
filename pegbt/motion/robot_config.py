"""Joint and jaw limits from a dVRK's own configuration: its `share/` folder (`pegbt run --robot-config DIR`).

The dVRK (jhu-dvrk/sawIntuitiveResearchKit) writes a PSM's limits in two JSON files with comments: the arm's
kinematic file `share/kinematic/PSM.json` (`DH.joints[0..2]`: yaw, pitch, insertion, each with `qmin`/`qmax`)
and the tool's file, e.g. `share/tool/LARGE_NEEDLE_DRIVER_400006.json` (`DH.joints[0..2]`: roll, wrist pitch,
wrist yaw; `jaw.qmin`/`jaw.qmax`). The robot's controller clips every command to these (`clip_jp`,
`clip_jaw_jp` in `mtsIntuitiveResearchKitArm.cpp`), so a plan must stay within them to land where it says.
The limits pegbt plans by are the robot's, narrowed further wherever `skills/psm.yaml` (the task's workspace)
is narrower: never wider than either. What a robot was sent (a recording's commands) is judged by the robot's
own limits alone (`DVRK_LIMITS` unless a `share/` folder is given): the planner's are narrower.
"""

from __future__ import annotations

import dataclasses
import math
import re
from pathlib import Path
from typing import Any

import json5
import numpy as np

from pegbt.boundedio import read_bytes
from pegbt.errors import PegbtError
from pegbt.motion.limits import ArmSettings, arm_settings

KINEMATIC_FILE = Path("kinematic") / "PSM.json"
MAX_FILE_BYTES = 1 << 20  # the dVRK's files are a few kB; json5 parses in Python, slowly
# No joint's limit lies farther than one turn (rad) nor an insertion farther than a metre (the PSM's is 0.24 m).
TURN, MAX_INSERTION = 2 * math.pi, 1.0
_TOOL_NAME = re.compile(r"[A-Za-z0-9_.-]{1,100}")
DEFAULT_TOOL = (
    "LARGE_NEEDLE_DRIVER_400006"  # the tool of the dVRK's PSM_KIN_SIMULATED_LARGE_NEEDLE_DRIVER arm file
)


@dataclasses.dataclass(frozen=True)
class RobotLimits:
    """Joint limits (yaw, pitch, insertion, roll, wrist pitch, wrist yaw) and jaw limits as the robot's files say."""

    lower: np.ndarray
    upper: np.ndarray
    jaw_lower: float
    jaw_upper: float


# The dVRK's figures for a PSM with the large needle driver: share/kinematic/PSM.json (yaw ±91°, pitch ±53°,
# insertion 0 to 0.24 m) and share/tool/LARGE_NEEDLE_DRIVER_400006.json (roll ±260°, wrist ±80°, jaw -40° to 80°).
DVRK_LIMITS = RobotLimits(
    lower=np.array([-1.588, -0.925025, 0.0, -4.53786, -1.39626, -1.39626]),
    upper=np.array([1.588, 0.925025, 0.24, 4.53786, 1.39626, 1.39626]),
    jaw_lower=-0.698132,
    jaw_upper=1.39626,
)


def _read(path: Path) -> dict[str, Any]:
    try:
        exists = path.is_file()
    except OSError as error:
        raise PegbtError(f"cannot read: {error.strerror}", file=path) from None
    if not exists:
        raise PegbtError("dVRK configuration file not found", file=path, field="--robot-config")
    data = read_bytes(path, MAX_FILE_BYTES, "dVRK configuration file")
    try:
        document = json5.loads(data.decode("utf-8"))
    except (ValueError, RecursionError) as error:  # UnicodeDecodeError is a ValueError
        reason = "nested too deeply" if isinstance(error, RecursionError) else _one_line(error)
        raise PegbtError(f"not a dVRK JSON file: {reason}", file=path) from None
    if not isinstance(document, dict):
        raise PegbtError("expected a JSON object", file=path)
    return document


def _one_line(error: Exception) -> str:
    return " ".join(str(error).split())[:300]


def _shown(value: float) -> str:
    """A number for a message: an integer too long for `str` by its size."""
    if isinstance(value, int) and value.bit_length() > 64:
        return f"an integer of {value.bit_length()} bits"
    return f"{value:.6g}"


def _number(value: Any, path: Path, field: str, bound: float) -> float:
    """A finite number within ±`bound` (a joint's unit: no arm's limit lies farther)."""
    finite = (
        isinstance(value, int) or isinstance(value, float) and math.isfinite(value)
    )  # ints are, however long
    if isinstance(value, bool) or not finite:
        raise PegbtError(f"expected a finite number, got {str(value)[:40]}", file=path, field=field)
    if abs(value) > bound:
        raise PegbtError(
            f"{_shown(value)} is beyond ±{bound:.4g}: not a joint limit in rad or m", file=path, field=field
        )
    return float(value)


def _joint_limits(path: Path, bounds: tuple[float, ...]) -> tuple[list[float], list[float], dict[str, Any]]:
    """`qmin`, `qmax` of the three DH joints of one dVRK file, each within its `bounds`, and the whole
    document."""
    document = _read(path)
    dh = document.get("DH")
    joints = dh.get("joints") if isinstance(dh, dict) else None
    if not isinstance(joints, list) or len(joints) != 3:
        raise PegbtError("expected DH.joints with 3 joints", file=path, field="DH.joints")
    lower, upper = [], []
    for index, joint in enumerate(joints):
        field = f"DH.joints[{index}]"
        if not isinstance(joint, dict):
            raise PegbtError("expected a joint object", file=path, field=field)
        low = _number(joint.get("qmin"), path, f"{field}.qmin", bounds[index])
        high = _number(joint.get("qmax"), path, f"{field}.qmax", bounds[index])
        if low >= high:
            raise PegbtError(f"qmin {low} is not below qmax {high}", file=path, field=field)
        lower.append(low)
        upper.append(high)
    return lower, upper, document


def read_robot_limits(share: str | Path, tool: str = DEFAULT_TOOL) -> RobotLimits:
    """The PSM's limits from the dVRK `share` folder: `kinematic/PSM.json` and `tool/TOOL.json`."""
    share = Path(share)
    if not _TOOL_NAME.fullmatch(tool):
        raise PegbtError(
            f"a tool is named by its file in share/tool/, without .json; got {tool[:60]!r}",
            field="--robot-tool",
        )
    if not share.is_dir():
        raise PegbtError("not a folder (give the dVRK's share/ folder)", file=share, field="--robot-config")
    arm_lower, arm_upper, _ = _joint_limits(share / KINEMATIC_FILE, (TURN, TURN, MAX_INSERTION))
    tool_path = share / "tool" / f"{tool}.json"
    tool_lower, tool_upper, tool_document = _joint_limits(tool_path, (TURN, TURN, TURN))
    jaw = tool_document.get("jaw")
    if not isinstance(jaw, dict):
        raise PegbtError("expected a jaw object with qmin and qmax", file=tool_path, field="jaw")
    return RobotLimits(
        lower=np.array(arm_lower + tool_lower),
        upper=np.array(arm_upper + tool_upper),
        jaw_lower=_number(jaw.get("qmin"), tool_path, "jaw.qmin", TURN),
        jaw_upper=_number(jaw.get("qmax"), tool_path, "jaw.qmax", TURN),
    )


def robot_limits(share: str | Path | None, tool: str = DEFAULT_TOOL) -> RobotLimits:
    """The robot's own limits: its `share` folder's when given, else the dVRK's figures (`DVRK_LIMITS`)."""
    return DVRK_LIMITS if share is None else read_robot_limits(share, tool)


def narrowed(settings: ArmSettings, limits: RobotLimits) -> ArmSettings:
    """`settings` with every joint and jaw limit narrowed to the robot's where the robot's is narrower."""
    lower = np.maximum(settings.lower, limits.lower)
    upper = np.minimum(settings.upper, limits.upper)
    if np.any(lower >= upper):
        raise PegbtError(
            f"{settings.name}: the robot's joint limits and skills/psm.yaml's leave no range for some joint "
            f"(lower {np.round(lower, 4).tolist()}, upper {np.round(upper, 4).tolist()})",
            field="--robot-config",
        )
    return dataclasses.replace(
        settings,
        lower=lower,
        upper=upper,
        jaw_lower=max(settings.jaw_lower, limits.jaw_lower),
        jaw_upper=min(settings.jaw_upper, limits.jaw_upper),
    )


def robot_arm_settings(arm: str, share: str | Path | None, tool: str = DEFAULT_TOOL) -> ArmSettings:
    """The settings of `arm` for a robot: `skills/psm.yaml`'s, narrowed by the dVRK's files when `share` is given."""
    settings = arm_settings(arm)
    return settings if share is None else narrowed(settings, read_robot_limits(share, tool))
