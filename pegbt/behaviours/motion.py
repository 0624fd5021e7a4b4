"""What the motion leaves share: `CarryLeaf`, the base of every motion that carries a block (failed at
once when the block slips out of the jaw), the jaw's test of a hold, and rising straight up first.

Every motion that starts low among the pegs first rises straight up to the transfer height
(`above_pegs_first`), so a tool never sweeps sideways through pegs and blocks.
"""

from __future__ import annotations

import math
from functools import partial

import numpy as np
from numpy.typing import NDArray
from py_trees.common import Status

from pegbt.behaviours.base import MotionLeaf, arm_param, keep_apart_param, key_param
from pegbt.behaviours.poses import height_above_pegs
from pegbt.executive.params import Param
from pegbt.motion.ik import solve_ik
from pegbt.motion.kinematics import forward_kinematics
from pegbt.motion.limits import ArmSettings
from pegbt.motion.settings import MotionSettings
from pegbt.motion.trajectory import Trajectory
from pegbt.motion.waypoints import TransferWaypoints
from pegbt.workcell import Workcell

HELD_ABOVE = 0.0  # rad: closed is -15°; a block stops a closing jaw at about +12°
LOW = 0.001  # m: a tip more than this below the transfer height rises before moving sideways
SLIP_CHECK = 0.1  # s: how often a transfer looks at the jaw for a slipping block


def above_pegs_first(
    cell: Workcell, motion: MotionSettings, arm: str, start: NDArray[np.float64], settings: ArmSettings
) -> list[NDArray[np.float64]]:
    """[joints straight above `start` at the transfer height] if the tip is low among the pegs, else []."""
    tip = forward_kinematics(start)
    rise = motion.transfer.transfer_height_above_peg_top - height_above_pegs(cell, arm, tip[:3, 3])
    if rise <= LOW:
        return []
    above = tip.copy()
    above[:3, 3] += rise * cell.up_in(arm)
    return [solve_ik(above, settings, what="straight above the tool")]


class CarryLeaf(MotionLeaf):
    """A motion carrying a held block: planned through `waypoints()` as the condition says, and failed at
    once, with the arm stopped, if the jaw closes past `held_above` (the block slipped out)."""

    may_step_back = False

    def waypoints(self) -> TransferWaypoints:
        raise NotImplementedError

    def begin(self) -> None:
        arm = self.param("arm")
        self.move(arm, partial(self.motion(arm).transfer, self.waypoints()), f"{arm} {self.name}")

    def started(self, trajectories: list[Trajectory]) -> None:
        duration = trajectories[0].duration
        self.put("plan_s", round(duration, 3))
        self.feedback_message = f"planned in {duration:.2f} s ({self.skills.condition})"

    def watch(self) -> Status:
        slipped = slip(self.client(self.param("arm")).jaw.measured_js.position[0], self.param("held_above"))
        if slipped:
            return self.fail(
                f"the block slipped from {self.param('arm')}'s jaw ({slipped}) during {self.name}"
            )
        if self.wake_at is not None:
            self.wake_at = min(self.wake_at, self.context.clock.now() + SLIP_CHECK)
        return Status.RUNNING


def slip(jaw_angle: float, held_above: float) -> str | None:
    """How the jaw shows that its block slipped out (it closed past `held_above`), or None if it still holds it."""
    angle = float(jaw_angle)
    return f"jaw at {math.degrees(angle):.0f}°" if angle <= held_above else None


def held_param() -> Param:
    return Param(
        "held_above",
        float,
        "a closed jaw stopped above this angle (rad) holds a block; one closing past it has lost its block",
        default=HELD_ABOVE,
        minimum=-0.3491,  # the jaw's range, skills/psm.yaml
        maximum=1.3963,
    )


def carry_params(*extra: Param, keep_apart: Param = keep_apart_param()) -> tuple[Param, ...]:
    return (
        arm_param(),
        *extra,
        held_param(),
        key_param("plan_s", "write", "the planned motion's duration, s"),
        keep_apart,
    )
