"""Per-arm limits and settings from `skills/psm.yaml`: the one place joint, velocity and jaw limits live.

The simulator refuses commands against them, the planner plans within them, and compensation never
leaves them; all read them through `arm_settings()`.
"""

from __future__ import annotations

from dataclasses import dataclass, replace
from functools import cache
from pathlib import Path

import numpy as np
from numpy.typing import ArrayLike, NDArray

from pegbt.errors import PegbtError
from pegbt.psm import N_JOINTS, joint_label
from pegbt.yamlfile import read_settings_file

SKILLS_DIR = Path(__file__).resolve().parents[2] / "skills"
PSM_SETTINGS = SKILLS_DIR / "psm.yaml"


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

    def at_speed(self, fraction: float) -> ArmSettings:
        """These settings for motions at `fraction` (0, 1] of the planner's speed, for a first run on a robot:
        velocities × fraction and accelerations × fraction², so that every planned motion keeps its path and
        takes 1 / fraction as long; the jaw at fraction of its velocity. The joint and velocity limits that
        guard every command stay as they are."""
        if fraction == 1.0:
            return self
        return replace(
            self,
            planner_velocity=self.planner_velocity * fraction,
            planner_acceleration=self.planner_acceleration * fraction**2,
            jaw_velocity=self.jaw_velocity * fraction,
        )

    def joint_violations(self, q: ArrayLike) -> list[str]:
        """Human-readable joint-limit violations of one joint vector; empty when it is inside."""
        q = np.asarray(q, dtype=float)
        if (q >= self.lower).all() and (q <= self.upper).all():  # NaN compares False: checked below
            return []
        problems = []
        for i, (value, low, high) in enumerate(zip(q, self.lower, self.upper)):
            if not np.isfinite(value):
                problems.append(f"{joint_label(i)} is {value}")
            elif not low <= value <= high:
                problems.append(f"{joint_label(i)} = {value:.4f} outside [{low:.4f}, {high:.4f}]")
        return problems

    def require_within(self, q: ArrayLike, what: str) -> NDArray[np.float64]:
        """`q` as a float array if it is inside the joint limits; else a `PegbtError` naming `what` and
        the violated limit."""
        q = np.asarray(q, dtype=float)
        if q.shape != (N_JOINTS,):
            raise PegbtError(f"expected {N_JOINTS} joint values, got shape {q.shape}", field=what)
        problems = self.joint_violations(q)
        if problems:
            raise PegbtError(f"outside the joint limits of {self.name}: " + "; ".join(problems), field=what)
        return q


@cache
def arm_settings(arm: str, path: Path = PSM_SETTINGS) -> ArmSettings:
    """Settings of `arm` (PSM1 or PSM2) from the skills file."""
    document = read_settings_file(path)
    document.mapping(("defaults", "arms"))
    arms = document["arms"]
    if arms.get(arm) is None:
        raise arms.error(f"no settings for arm {arm!r}", field_name=arms.child_path(arm))
    data = arms[arm]
    data.mapping(("joint_limits", "velocity_limits", "planner", "jaw", "control_period", "home_tip"))
    limits, planner, jaw = data["joint_limits"], data["planner"], data["jaw"]
    limits.mapping(("lower", "upper"))
    planner.mapping(("velocity", "acceleration"))
    jaw.mapping(("lower", "upper", "velocity"))
    settings = ArmSettings(
        name=arm,
        lower=limits["lower"].array((N_JOINTS,)),
        upper=limits["upper"].array((N_JOINTS,)),
        velocity=data["velocity_limits"].array((N_JOINTS,), positive=True),
        planner_velocity=planner["velocity"].array((N_JOINTS,), positive=True),
        planner_acceleration=planner["acceleration"].array((N_JOINTS,), positive=True),
        jaw_lower=jaw["lower"].number(),
        jaw_upper=jaw["upper"].number(),
        jaw_velocity=jaw["velocity"].number(positive=True),
        control_period=data["control_period"].number(positive=True),
        home_tip=data["home_tip"].array((3,)),
    )
    if np.any(settings.lower >= settings.upper):
        raise limits.error("every lower joint limit must be below its upper limit")
    if settings.jaw_lower >= settings.jaw_upper:
        raise jaw.error("the lower jaw limit must be below the upper one")
    return settings
