"""The physical lower bound of a peg-transfer trial: the least time a dVRK with pegbt's planner limits
(`skills/psm.yaml`: joint velocity and acceleration, the jaw's velocity) could take for each transfer,
with perception and planning free.

A transfer meets only the constraints no way of doing it escapes: the tool reaches the block (at rest, for
the jaw to close on it), the jaw closes from an opening that passes the block's wall to the wall, the block
rises until its hole clears its peg (its bottom at the peg's top: the tip `block_below_tip` above it), comes
down until its hole is on the goal peg (the same height over that peg), stops, and falls the rest of the way
when the jaw lets go. A jaw that grips the wall has one jaw inside the block's hole: that jaw (2 ×
`jaw_radius` thick) fills the gap between the peg and the hole's wall (hole radius less peg radius), so it
can only move along the peg's axis while its tip is below the block's top. The approach therefore passes
through the grasp's point at the block's top (the jaw entering the hole), and a tool that let go of a block
below the fallen block's top first rises along that axis to it (the jaw leaving the hole) before it
moves over. Everything else pegbt does (the transfer height, the drop height, the approach from
above, the peg channels and their margin, the jaw's full opening and squeeze) is its choice, and the breakdown of
`pegbt bench limit` charges it there. The block is carried at the clear height, above every peg and block
on the board; the other arm is taken as out of the way.

Each segment is time-optimal under the planner's limits with ruckig (infinite jerk, as `pegbt bench motion`'s
rest-to-rest bound). A motion from rest at A that must pass through B and end at rest at C takes at least
the time to reach B from rest plus the time from B to rest at C, each without stopping at B; with
bang-coast-bang joints, reaching B from rest with any speed takes half the rest-to-rest time to 2B − A
(the first half of that symmetric profile), so both halves are ruckig durations too. The carry's bound is
the larger of that and the rest-to-rest time from A to C.

Two arms: each arm's transfers follow one another; arms work at once; a handover is a rendezvous: the giver
holds the block at pegbt's meeting point, the receiver's jaw closes there once both have arrived, then the
receiver carries it to the goal peg. A trial's bound per transfer is, as for pegbt's own figure, the union
of the transfers' start-to-placement intervals over their number, so the busier arm sets it.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass, field
from functools import partial

import numpy as np
from numpy.typing import NDArray

from pegbt.frames import apply_rigid, rigid_transform
from pegbt.motion.handover import handover_meeting_point
from pegbt.motion.ik import solve_ik
from pegbt.motion.limits import ArmSettings, arm_settings
from pegbt.motion.settings import MotionSettings, motion_settings
from pegbt.motion.waypoints import tool_down_rotation
from pegbt.workcell import Workcell, workcell

GRAVITY = 9.81  # m/s², the block's fall onto the goal peg
TRANSFERS_PER_HALF = 6  # the reference trials park both arms and look again after six transfers
LOWER_GRID = 8  # heights tried for where the jaw opens over the goal peg


@dataclass(frozen=True)
class Heights:
    """Tip heights above the peg tops (m) a transfer's bound may go through: where the block is lifted
    clear of the pick peg, where the carry ends over the goal peg (the jaw opens there; the block falls the
    rest), and where the approach passes above the block (None: straight onto the grasp). Where several
    heights are allowed, each segment takes its quickest: the least of each segment is below the least
    of their sum."""

    lifts: tuple[float, ...]
    lowers: tuple[float, ...]
    approach: float | None = None

    @staticmethod
    def minimal(motion: MotionSettings) -> Heights:
        """The block's bottom at or above the peg's top going up, at or below it coming down (any height
        down to resting, on a grid that holds pegbt's own); the jaw entering the block's hole from its top."""
        transfer = motion.transfer
        hanging, resting = transfer.block_below_tip, -transfer.block_top_below_peg_top - transfer.grasp_depth
        lowers = {*np.linspace(resting, hanging, LOWER_GRID).tolist(), transfer.drop_height_above_peg_top}
        return Heights(
            (hanging, transfer.transfer_height_above_peg_top),
            tuple(sorted(lowers)),
            -transfer.block_top_below_peg_top,
        )

    @staticmethod
    def pegbt(motion: MotionSettings) -> Heights:
        """pegbt's own waypoints: up to the transfer height, down to the drop height, approach from just
        above the block (the bound of a motion through them, not pegbt's path)."""
        transfer = motion.transfer
        return Heights(
            (transfer.transfer_height_above_peg_top,),
            (transfer.drop_height_above_peg_top,),
            -transfer.block_top_below_peg_top + transfer.approach_above_block,
        )


@dataclass(frozen=True)
class Start:
    """Where an arm's next motion may start from: its joints at rest, and the joints it must pass first
    (its jaw leaving a block's hole along the peg's axis), if any."""

    joints: NDArray[np.float64]
    exit: NDArray[np.float64] | None = None

    def via(self) -> list[NDArray[np.float64]]:
        return [] if self.exit is None else [self.exit]


@dataclass
class SegmentTimes:
    """Seconds of one arm's bound, by what it is spent on."""

    motion: float = 0.0
    jaw: float = 0.0  # the jaw closing on the block, and the block falling onto its peg

    @property
    def total(self) -> float:
        return self.motion + self.jaw


@dataclass
class TrialBound:
    """Per transfer (in the trial's order) its bound interval; per arm, what its busy time went to."""

    intervals: list[tuple[float, float]] = field(default_factory=list)
    arms: dict[str, SegmentTimes] = field(default_factory=dict)

    @property
    def per_transfer_s(self) -> float:
        """The union of the intervals over their number (`TrialResult.mean_transfer_time_s`'s measure)."""
        busy, reach = 0.0, -math.inf
        for start, end in sorted(self.intervals):
            busy += max(0.0, end - max(start, reach))
            reach = max(reach, end)
        return busy / len(self.intervals) if self.intervals else math.nan


def rest_to_rest(start: NDArray[np.float64], goal: NDArray[np.float64], settings: ArmSettings) -> float:
    """Time-optimal rest-to-rest duration under the planner's joint limits (ruckig, infinite jerk)."""
    import ruckig

    generator = ruckig.Ruckig(6)
    inputs, trajectory = ruckig.InputParameter(6), ruckig.Trajectory(6)
    inputs.current_position, inputs.target_position = start.tolist(), goal.tolist()
    inputs.max_velocity = settings.planner_velocity.tolist()
    inputs.max_acceleration = settings.planner_acceleration.tolist()
    inputs.max_jerk = [math.inf] * 6
    result = generator.calculate(inputs, trajectory)
    if result not in (ruckig.Result.Working, ruckig.Result.Finished):
        raise RuntimeError(f"ruckig could not time a rest-to-rest move: {result}")
    return float(trajectory.duration)


def through(
    start: NDArray[np.float64],
    via: list[NDArray[np.float64]],
    goal: NDArray[np.float64],
    settings: ArmSettings,
) -> float:
    """Least time from rest at `start` through each of `via` (at most two) to rest at `goal` (module
    docstring): each way of splitting the path at the via points gives a bound; the largest holds."""
    bounds = [rest_to_rest(start, goal, settings)]
    if via:
        first, last = via[0], via[-1]
        middle = 0.0
        if len(via) == 2:
            middle = float(np.max(np.abs(last - first) / settings.planner_velocity))
        reach = 0.5 * rest_to_rest(start, 2 * first - start, settings)
        stop = 0.5 * rest_to_rest(goal, 2 * last - goal, settings)
        bounds.append(reach + middle + stop)
    return max(bounds)


class Bound:
    """The bound's poses and segment times for one work cell and the planner limits of both arms."""

    def __init__(
        self,
        heights: Heights | None = None,
        cell: Workcell | None = None,
        motion: MotionSettings | None = None,
    ) -> None:
        self.cell, self.motion = cell or workcell(), motion or motion_settings()
        self.heights = heights or Heights.minimal(self.motion)
        self.settings = {arm: arm_settings(arm) for arm in ("PSM1", "PSM2")}
        jaw = self.settings["PSM1"].jaw_velocity
        block, tool = self.cell.block, self.cell.tool
        wall = block.edge_distance - block.hole_radius
        gripped = 2.0 * math.asin(min(1.0, wall / 2.0 / tool.jaw_length))
        passes = 2.0 * math.asin(min(1.0, (wall + 2.0 * tool.jaw_radius) / 2.0 / tool.jaw_length))
        self.jaw_close_s = (passes - gripped) / jaw

    def joints(self, arm: str, peg: int, height: float) -> NDArray[np.float64]:
        """The arm's joints with the tip `height` above peg `peg`'s top, tool down."""
        up = self.cell.up_in(arm)
        position = self.cell.peg_tops_in(arm)[peg] + height * up
        return solve_ik(rigid_transform(tool_down_rotation(0.0, up), position), self.settings[arm])

    def grasp_height(self) -> float:
        transfer = self.motion.transfer
        return -transfer.block_top_below_peg_top - transfer.grasp_depth

    def home(self, arm: str) -> NDArray[np.float64]:
        up = self.cell.up_in(arm)
        pose = rigid_transform(tool_down_rotation(0.0, up), self.settings[arm].home_tip)
        return solve_ik(pose, self.settings[arm])

    def meeting(self, arm: str) -> NDArray[np.float64]:
        """The arm's joints with its tip at pegbt's handover meeting point, tool down."""
        point = apply_rigid(self.cell.board_to_arm(arm), handover_meeting_point(self.cell, self.motion))
        pose = rigid_transform(tool_down_rotation(0.0, self.cell.up_in(arm)), point)
        return solve_ik(pose, self.settings[arm])

    def fall_s(self, height: float) -> float:
        """The block's fall onto its goal peg when the jaw opens with the tip `height` above the peg's top."""
        fall = height - self.grasp_height()
        return math.sqrt(2.0 * max(fall, 0.0) / GRAVITY)

    def approach(self, arm: str, starts: list[Start], peg: int) -> tuple[NDArray[np.float64], float]:
        """The grasp's joints and the least time to them from rest at the quickest of `starts`."""
        grasp = self.joints(arm, peg, self.grasp_height())
        via = [] if self.heights.approach is None else [self.joints(arm, peg, self.heights.approach)]
        return grasp, min(
            through(start.joints, start.via() + via, grasp, self.settings[arm]) for start in starts
        )

    def reach(self, arm: str, starts: list[Start], goal: NDArray[np.float64]) -> float:
        """The least time from rest at the quickest of `starts` to rest at `goal`."""
        return min(through(start.joints, start.via(), goal, self.settings[arm]) for start in starts)

    def lift_to(self, arm: str, grasp: NDArray[np.float64], pick: int, goal: NDArray[np.float64]) -> float:
        """The least time from rest at `grasp` on peg `pick`, lifting the block clear, to rest at `goal`."""
        return min(
            through(grasp, [self.joints(arm, pick, lift)], goal, self.settings[arm])
            for lift in self.heights.lifts
        )

    def lower(
        self, arm: str, place: int, moved: Callable[[NDArray[np.float64]], float]
    ) -> tuple[list[Start], float, float]:
        """Where the jaw may open over `place` (each with the way out of the fallen block's hole), and the
        least motion `moved` (seconds to one of them) and block's fall over those heights, as (starts of
        the next motion, motion, fall)."""
        top = -self.motion.transfer.block_top_below_peg_top  # the fallen block's top
        out = self.joints(arm, place, top)
        ends = [
            Start(self.joints(arm, place, height), out if height < top else None)
            for height in self.heights.lowers
        ]
        motion, fall = min(
            ((moved(end.joints), self.fall_s(height)) for end, height in zip(ends, self.heights.lowers)),
            key=sum,
        )
        return ends, motion, fall


def trial_bound(transfers: list[tuple[str, int, int]], bound: Bound | None = None) -> TrialBound:
    """The bound of a trial whose transfers are (arms, pick peg, place peg) in the order they began (arms:
    `PSM1`, or `GIVER→RECEIVER` for a handover)."""
    bound = bound or Bound()
    result = TrialBound(arms={arm: SegmentTimes() for arm in bound.settings})
    free = dict.fromkeys(bound.settings, 0.0)
    at: dict[str, list[Start]] = {}
    for index, (arms, pick, place) in enumerate(transfers):
        if index % TRANSFERS_PER_HALF == 0:  # both arms park and the camera looks: a fresh start
            free = dict.fromkeys(free, max(free.values()))
            at = {arm: [Start(bound.home(arm))] for arm in bound.settings}
        giver, *others = arms.split("→")
        grasp, reach = bound.approach(giver, at[giver], pick)
        started = free[giver]
        times = result.arms[giver]
        times.motion += reach
        times.jaw += bound.jaw_close_s
        if not others:
            ends, carry, fall = bound.lower(giver, place, partial(bound.lift_to, giver, grasp, pick))
            times.motion += carry
            times.jaw += fall
            free[giver], at[giver] = started + reach + bound.jaw_close_s + carry, ends
            result.intervals.append((started, free[giver] + fall))
            continue
        receiver = others[0]
        meet_g, meet_r = bound.meeting(giver), bound.meeting(receiver)
        to_meet = bound.lift_to(giver, grasp, pick, meet_g)
        settings = bound.settings[receiver]
        to_receive = bound.reach(receiver, at[receiver], meet_r)
        arrived = max(started + reach + bound.jaw_close_s + to_meet, free[receiver] + to_receive)
        taken = arrived + bound.jaw_close_s
        ends, place_s, fall = bound.lower(receiver, place, partial(rest_to_rest, meet_r, settings=settings))
        times.motion += to_meet
        result.arms[receiver].motion += to_receive + place_s
        result.arms[receiver].jaw += bound.jaw_close_s + fall
        free[giver], at[giver] = taken, [Start(meet_g)]
        free[receiver], at[receiver] = taken + place_s, ends
        result.intervals.append((started, free[receiver] + fall))
    return result
