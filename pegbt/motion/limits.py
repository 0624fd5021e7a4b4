"""Per-arm limits and settings from `skills/psm.yaml`: the one place joint, velocity and jaw limits live.

The simulator refuses commands against them, the planner plans within them, and compensation never
leaves them; all read them through `arm_settings()`.
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import lru_cache
from pathlib import Path

import numpy as np
import yaml
from numpy.typing import ArrayLike, NDArray

from pegbt.errors import PegbtError

SKILLS_DIR = Path(__file__).resolve().parents[2] / "skills"
PSM_SETTINGS = SKILLS_DIR / "psm.yaml"
JOINT_NAMES = ("yaw", "pitch", "insertion", "roll", "wrist_pitch", "wrist_yaw")


@dataclass(frozen=True)
class ArmSettings:
    """Limits and defaults of one PSM."""

    name: str
    lower: NDArray[np.float64]
    upper: NDArray[np.float64]
    velocity: NDArray[np.float64]
    planner_velocity: NDArray[np.float64]
    planner_acceleration: NDArray[np.float64]
    jaw_lower: float
    jaw_upper: float
    jaw_velocity: float
    control_period: float
    home_tip: NDArray[np.float64]

    def joint_violations(self, q: ArrayLike) -> list[str]:
        """Human-readable joint-limit violations of one joint vector; empty when it is inside."""
        q = np.asarray(q, dtype=float)
        problems = []
        for i, (value, low, high) in enumerate(zip(q, self.lower, self.upper)):
            if not np.isfinite(value):
                problems.append(f"q{i + 1} ({JOINT_NAMES[i]}) is {value}")
            elif not low <= value <= high:
                problems.append(f"q{i + 1} ({JOINT_NAMES[i]}) = {value:.4f} outside [{low:.4f}, {high:.4f}]")
        return problems

    def require_within(self, q: ArrayLike, what: str) -> NDArray[np.float64]:
        """`q` as a float array if it is inside the joint limits; else a `PegbtError` naming `what` and
        the violated limit."""
        q = np.asarray(q, dtype=float)
        if q.shape != (6,):
            raise PegbtError(f"expected 6 joint values, got shape {q.shape}", field=what)
        problems = self.joint_violations(q)
        if problems:
            raise PegbtError(f"outside the joint limits of {self.name}: " + "; ".join(problems), field=what)
        return q


def _vector(data: dict, key: str, path: Path, arm: str) -> NDArray[np.float64]:
    value = np.asarray(data[key], dtype=float)
    if value.shape != (6,) or not np.all(np.isfinite(value)):
        raise PegbtError(f"expected 6 finite numbers, got {data[key]!r}", file=path, field=f"arms.{arm}.{key}")
    return value


@lru_cache(maxsize=None)
def arm_settings(arm: str, path: Path = PSM_SETTINGS) -> ArmSettings:
    """Settings of `arm` (PSM1 or PSM2) from the skills file."""
    try:
        document = yaml.safe_load(path.read_text())
        data = document["arms"][arm]
    except OSError as error:
        raise PegbtError(f"cannot read arm settings: {error}", file=path) from None
    except (KeyError, TypeError):
        raise PegbtError(f"no settings for arm {arm!r}", file=path, field="arms") from None
    try:
        limits, planner, jaw = data["joint_limits"], data["planner"], data["jaw"]
        settings = ArmSettings(
            name=arm,
            lower=_vector(limits, "lower", path, arm),
            upper=_vector(limits, "upper", path, arm),
            velocity=_vector(data, "velocity_limits", path, arm),
            planner_velocity=_vector(planner, "velocity", path, arm),
            planner_acceleration=_vector(planner, "acceleration", path, arm),
            jaw_lower=float(jaw["lower"]),
            jaw_upper=float(jaw["upper"]),
            jaw_velocity=float(jaw["velocity"]),
            control_period=float(data["control_period"]),
            home_tip=np.asarray(data["home_tip"], dtype=float),
        )
    except KeyError as missing:
        raise PegbtError(f"missing setting {missing.args[0]!r}", file=path, field=f"arms.{arm}") from None
    for key, value in (("planner.velocity", settings.planner_velocity), ("planner.acceleration", settings.planner_acceleration)):
        if np.any(value <= 0):
            raise PegbtError(f"planner limits must be positive, got {value.tolist()}", file=path, field=f"arms.{arm}.{key}")
    if np.any(settings.lower >= settings.upper):
        raise PegbtError("every lower joint limit must be below its upper limit", file=path, field=f"arms.{arm}.joint_limits")
    return settings
