"""The physical lower bound of a peg-transfer trial: the least time a dVRK with pegbt's planner limits
(`skills/psm.yaml`: joint velocity and acceleration, the jaw's velocity) could take for each transfer,
with perception and planning free.

A transfer meets only the constraints no way of doing it escapes: the tool reaches the block (at rest, for the
jaw to close on it), the jaw closes from an opening that passes the block's wall to the wall, the block rises
until its hole clears its peg (its bottom at the peg's top: the tip `block_below_tip` above it), comes down
until its hole is on the goal peg (the same height over that peg), stops, and falls the rest of the way when
the jaw lets go; if the jaw lets go lower, with the hole already round the goal peg, the block came down that
peg's axis from that height (its hole's wall would strike the peg from the side). Carrying it clear of the
other pegs and blocks adds nothing: they end at or below the peg tops, under the lifted block, and a lower
path between them is not the bound's to exclude; the other arm is taken as out of the way. A jaw that grips
the wall has one jaw inside the block's hole: that jaw (2 × `jaw_radius` thick) fills the gap between the peg
and the hole's wall (hole radius less peg radius), so it can only move along the peg's axis while its tip is
below the block's top. The approach therefore passes through the grasp's point at the block's top (the jaw
entering the hole), and a tool that let go of a block below the fallen block's top first rises along that axis
to it (the jaw leaving the hole) before it moves over. Everything else pegbt does (the transfer height, the
drop height, the approach from above, the peg channels and their margin, the jaw's opening, squeeze and
opening to let go) is its choice, and the breakdown of `pegbt bench limit` charges it there.

Each segment is time-optimal under the planner's limits (infinite jerk, as `pegbt bench motion`'s
rest-to-rest bound, which is ruckig's). A motion from rest at A that must pass through B and end at rest at C
passes B at some joint velocity v (within the velocity limits) at some time t₁, and ends t₂ later: each
joint j must reach (B_j, v_j) from rest in at most t₁ and stop from there at C_j in at most t₂ (its
time-optimal bang-coast-bang durations, `reach_s`). Whatever v is, t₁ + t₂ is at least the least sum that
every joint admits with its own v_j (`via_s`): a relaxation, so never above a feasible motion, and the
velocity at B is continuous (no jump, as a sum of two rest-to-rest halves would allow).

Two arms: each arm's transfers follow one another; arms work at once; a handover is a rendezvous at pegbt's
meeting point (the reference's exchange: the receiver descends and closes, the giver opens and rises; the
bound is of a handover at pegbt's meeting point as it is of a transfer at pegbt's pegs; the receiver's grasp
is taken at the giver's point). Each arm's jaw enters and leaves the block's hole along its axis through the
block's top, as over a peg: the hole is empty here, but a jaw straddling the wall can move sideways only as
far as its opening leaves room either side (at the least opening the bound allows, none), and a tool leaving
downwards would take its shaft (8.4 mm) through the hole (7.2 mm). So the receiver passes its grasp's point at
the block's top on its way to the grasp and comes to rest there no sooner than the giver holds the block out;
its jaw enters the hole only once the block is on its final axis (it may while the giver still brings the
block along that axis, as pegbt's does), so the giver's carry and the receiver's descent meet on that axis
(`pegbt.bench.limit_axis`); its jaw closes to its squeeze; only then does the giver's jaw open, from its squeeze
to the angle at which it clears the wall (`jaw_open_s`), its arm still meanwhile: a jaw still on the wall grips,
and an arm moving while the receiver holds the block still drags it through one of the grips; then the giver
passes its own grasp's point at the block's top on its way to its next pick; the receiver carries the block off
only once the giver's jaw has opened and left the hole, then to the goal peg. A jaw letting go onto a peg has no
such wait: nobody else holds the block, so its opening may overlap the carry's end.

The jaw's angles: `jaw_on_wall` (12°) puts the jaws' centre lines at the tip on the wall's faces; the jaws are
`jaw_radius` round (`skills/workcell.yaml`), so there they are a jaw radius into the wall, a squeeze (the least
the bound grants: the close and the opening run between it and the clearing angle). Each jaw's surface leaves
the wall at `jaw_clear_of_wall` (24°, as `skills/motion.yaml` has it for `jaw_release`): the wall (the block's flat
edge less its hole, `peg-transfer-geometry.md`, "Block") plus a jaw radius either side at the jaw's length
from its hinge (L4, "PSM kinematics"). A jaw whose faces run straight from the hinge meets the wall's top edge,
`grasp_depth` above the tip, at 23.1°: the same within 1.2° (0.0035 s of the jaw). A trial's bound per transfer is, as for pegbt's own figure, the union of the transfers'
start-to-placement intervals over their number, so the busier arm sets it."""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass, field
from functools import lru_cache, partial

import numpy as np
from numpy.typing import NDArray

from pegbt.bench.limit_axis import CELL, CELL_SAMPLES, SPAN, Limits, on_axis_s
from pegbt.bench.limit_joint import reach_s
from pegbt.frames import apply_rigid, rigid_transform
from pegbt.motion.handover import handover_meeting_point, jaw_clear_of_wall, jaw_on_wall
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


def pass_s(start: NDArray[np.float64], via: NDArray[np.float64], settings: ArmSettings) -> float:
    """Least time from rest at `start` to pass `via` at any velocity, each joint at its own best (so also, run
    backwards, the least from passing `via` to rest at `start`)."""
    vmax, amax = settings.planner_velocity.astype(float), settings.planner_acceleration.astype(float)
    distance = via - start
    best = np.sign(distance) * np.minimum(np.sqrt(2 * amax * np.abs(distance)), vmax)
    return float(np.max(reach_s(distance, best, vmax, amax)))


VIA_GRIDS = (512, 64)  # arrival times tried through a via point, then within each interval split again
VIA_SPLIT = 8  # intervals split again: those with the least rounded-down value (the others stay so)
BISECTIONS = 30


def via_s(
    start: NDArray[np.float64], via: NDArray[np.float64], goal: NDArray[np.float64], settings: ArmSettings
) -> float:
    """Least time from rest at `start` through `via` (at any velocity) to rest at `goal`, rounded down."""
    vmax, amax = settings.planner_velocity.astype(float), settings.planner_acceleration.astype(float)
    return _via_s(start, via, goal, vmax, amax)


def _via_s(
    start: NDArray[np.float64],
    via: NDArray[np.float64],
    goal: NDArray[np.float64],
    vmax: NDArray[np.float64],
    amax: NDArray[np.float64],
) -> float:
    """Least time from rest at `start` through `via` (at any velocity) to rest at `goal`, rounded down.

    For joint j, f_j(v) = `reach_s` to (via_j, v) and g_j(v) the time from (via_j, v) to rest at goal_j
    (the reverse of reaching via_j from rest at goal_j with −v) fall then rise in v, so the velocities
    reached by t₁ form an interval around f_j's minimiser, and h_j(t₁), the least g_j over it, is g_j at
    the point of that interval nearest g_j's minimiser. The bound is min over t₁ of t₁ + max_j h_j(t₁);
    h_j falls with t₁, so on a grid t₀ < t₁ < … it is at least min_k t_k + max_j h_j(t_{k+1}); each
    interval is taken at the outer end of its bisection bracket (wider: h smaller)."""
    d_in, d_out = via - start, via - goal

    def f(v: NDArray[np.float64]) -> NDArray[np.float64]:
        return reach_s(d_in, v, vmax, amax)

    def g(v: NDArray[np.float64]) -> NDArray[np.float64]:
        return reach_s(d_out, -v, vmax, amax)

    best_in = np.sign(d_in) * np.minimum(np.sqrt(2 * amax * np.abs(d_in)), vmax)
    best_out = -np.sign(d_out) * np.minimum(np.sqrt(2 * amax * np.abs(d_out)), vmax)
    first, last = float(np.max(f(best_in))), float(np.max(f(best_out)))
    if last <= first:
        return first + float(np.max(g(best_out)))

    def least_out(times: NDArray[np.float64]) -> NDArray[np.float64]:
        """max_j h_j(t) per time t, h_j's interval taken at the outer end of its bisection bracket."""
        column = times[:, None]
        shape = (len(times), len(vmax))
        ends = []
        for limit in (-vmax, vmax):  # bisect each side of f_j's minimiser
            outside, inside = np.broadcast_to(limit, shape).copy(), np.broadcast_to(best_in, shape).copy()
            for _ in range(BISECTIONS):
                mid = (outside + inside) / 2
                reached = f(mid) <= column
                inside, outside = np.where(reached, mid, inside), np.where(reached, outside, mid)
            ends.append(outside)
        return np.max(g(np.clip(best_out, *ends)), axis=1)

    # on [t_k, t_k+1], t₁ + max_j h_j(t₁) ≥ t_k + max_j h_j(t_k+1); past `last` it only grows. Intervals
    # whose rounded-down value is above one the sum reaches are settled; the others are split again.
    reached = last + float(np.max(g(best_out)))
    settled, intervals = reached, np.array([[first, last]])
    for grid in VIA_GRIDS:
        times = np.linspace(intervals[:, 0], intervals[:, 1], grid + 1, axis=1)
        ends = least_out(times.ravel()).reshape(times.shape)
        reached = min(reached, float(np.min(times + ends)))
        lows = (times[:, :-1] + ends[:, 1:]).ravel()
        split = lows < min(reached, np.sort(lows)[min(VIA_SPLIT, lows.size) - 1] + 1e-12)
        settled = min([settled, *lows[~split]])
        intervals = np.stack([times[:, :-1].ravel()[split], times[:, 1:].ravel()[split]], axis=1)
        if not split.any():
            return settled
    return min(settled, float(np.min(lows[split])))


@lru_cache(maxsize=1 << 14)
def _via_cached(
    start: tuple[float, ...],
    via: tuple[float, ...],
    goal: tuple[float, ...],
    limits: tuple[tuple[float, ...], tuple[float, ...]],
) -> float:
    """`via_s` remembered: a trial's bound and the bench's meet the same poses again and again."""
    vmax, amax = (np.array(values) for values in limits)
    return _via_s(np.array(start), np.array(via), np.array(goal), vmax, amax)


def through(
    start: NDArray[np.float64],
    via: list[NDArray[np.float64]],
    goal: NDArray[np.float64],
    settings: ArmSettings,
) -> float:
    """Least time from rest at `start` through each of `via` (at most two) to rest at `goal`: the
    rest-to-rest time, the bound through each via point on its own (`via_s`), and with two, reaching the
    first and leaving the last at any velocity with the straight line between them at full speed; each
    drops constraints, so the largest holds."""
    bounds = [rest_to_rest(start, goal, settings)]
    limits = (tuple(settings.planner_velocity), tuple(settings.planner_acceleration))
    bounds += [_via_cached(tuple(start), tuple(point), tuple(goal), limits) for point in via]
    if len(via) == 2:
        first, last = via
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
        self.jaw_close_s = (jaw_clear_of_wall(self.cell) - jaw_on_wall(self.cell)) / jaw  # to its squeeze
        self.jaw_open_s = self.jaw_close_s  # back again, at the jaw's velocity limit
        self._axis: dict[
            tuple[str, str], tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.float64]]
        ] = {}
        self._held: dict[tuple[str, str, int], float] = {}

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

    def meeting(self, arm: str, above: float = 0.0) -> NDArray[np.float64]:
        """The arm's joints with its tip `above` pegbt's handover meeting point along the pegs' axis, tool down."""
        up = self.cell.up_in(arm)
        point = apply_rigid(self.cell.board_to_arm(arm), handover_meeting_point(self.cell, self.motion))
        pose = rigid_transform(tool_down_rotation(0.0, up), point + above * up)
        return solve_ik(pose, self.settings[arm])

    def entry_above_grasp(self) -> float | None:
        """How far above its grasp the tool passes on its way to it: the block's top (where its jaw enters the
        hole) plus what `heights.approach` adds over it; None where the heights approach straight."""
        if self.heights.approach is None:
            return None
        return self.heights.approach - self.grasp_height()

    def exchange(self, giver: str, receiver: str, starts: list[Start]) -> Exchange:
        """The rendezvous of a handover from `giver` to `receiver` (at rest at the quickest of `starts`)."""
        depth = self.motion.transfer.grasp_depth  # the grip below the block's top
        meet_g, meet_r = self.meeting(giver), self.meeting(receiver)
        out = self.meeting(giver, depth)
        entry = self.entry_above_grasp()
        via = () if entry is None else (self.meeting(receiver, entry),)
        return Exchange(
            giver=meet_g,
            giver_out=out,
            receiver=meet_r,
            to_receive=self.reach(receiver, starts, meet_r, via),
            opening=self.jaw_open_s,
            let_go=self.jaw_open_s + pass_s(meet_g, out, self.settings[giver]),
        )

    def axis_cells(
        self, giver: str, receiver: str
    ) -> tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.float64]]:
        """Per cell of the meeting axis (`limit_axis`), the giver's joints' least and greatest values there and
        the receiver's least time from its tip at the block's top in that cell to rest at its grasp; then
        the axis at ±`SPAN`, with no such time. Remembered per pair of arms."""
        key = (giver, receiver)
        if key not in self._axis:
            samples = np.linspace(-SPAN, SPAN, round(2 * SPAN / CELL) * CELL_SAMPLES + 1)
            depth = self.motion.transfer.grasp_depth
            on_axis = np.array([self.meeting(giver, height) for height in samples])
            entries = np.array([self.meeting(receiver, depth + height) for height in samples])
            spans = [slice(k, k + CELL_SAMPLES + 1) for k in range(0, len(samples) - 1, CELL_SAMPLES)]
            grasp, settings = self.meeting(receiver), self.settings[receiver]
            after = [pass_s(grasp, np.clip(grasp, *_bounds(entries[span])), settings) for span in spans]
            bounds = [_bounds(on_axis[span]) for span in spans] + [(on_axis[0],) * 2, (on_axis[-1],) * 2]
            self._axis[key] = (
                np.array([low for low, _ in bounds]),
                np.array([high for _, high in bounds]),
                np.array([*after, 0.0, 0.0]),
            )
        return self._axis[key]

    def held_on_axis(self, giver: str, receiver: str, pick: int) -> float:
        """The least time from rest at the giver's grasp on `pick` until both arms rest at the meeting point,
        the receiver's jaw entering the block only on its final axis (`limit_axis.on_axis_s`)."""
        key = (giver, receiver, pick)
        if key not in self._held:
            low, high, after = self.axis_cells(giver, receiver)
            grasp, settings = self.joints(giver, pick, self.grasp_height()), self.settings[giver]
            limits = Limits(
                settings.planner_velocity.astype(float), settings.planner_acceleration.astype(float)
            )
            self._held[key] = min(
                on_axis_s(
                    grasp, self.joints(giver, pick, lift), low, high, self.meeting(giver), after, limits
                )
                for lift in self.heights.lifts
            )
        return self._held[key]

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

    def reach(
        self,
        arm: str,
        starts: list[Start],
        goal: NDArray[np.float64],
        via: tuple[NDArray[np.float64], ...] = (),
    ) -> float:
        """The least time from rest at the quickest of `starts`, through `via`, to rest at `goal`."""
        return min(through(start.joints, [*start.via(), *via], goal, self.settings[arm]) for start in starts)

    def lift_to(
        self,
        arm: str,
        grasp: NDArray[np.float64],
        pick: int,
        goal: NDArray[np.float64],
        via: tuple[NDArray[np.float64], ...] = (),
    ) -> float:
        """The least time from rest at `grasp` on peg `pick`, lifting the block clear, through `via` (at
        most one), to rest at `goal`."""
        return min(
            through(grasp, [self.joints(arm, pick, lift), *via], goal, self.settings[arm])
            for lift in self.heights.lifts
        )

    def lower(
        self,
        arm: str,
        place: int,
        moved: Callable[[NDArray[np.float64], tuple[NDArray[np.float64], ...]], float],
    ) -> tuple[list[Start], float, float]:
        """Where the jaw may open over `place` (each with the way out of the fallen block's hole), and the
        least motion `moved` (seconds to one of them, through the points it is given) and block's fall
        over those heights, as (starts of the next motion, motion, fall). A jaw opening with the block's
        bottom below the peg's top has brought the block's hole down onto the peg along its axis (from the
        side, the hole's wall would strike the peg): the motion passes the tip `block_below_tip` over the
        peg's top first, where the block's bottom meets it, as the lift leaves the pick peg there."""
        transfer = self.motion.transfer
        top = -transfer.block_top_below_peg_top  # the fallen block's top
        out = self.joints(arm, place, top)
        onto = (self.joints(arm, place, transfer.block_below_tip),)
        ends = [
            Start(self.joints(arm, place, height), out if height < top else None)
            for height in self.heights.lowers
        ]
        motion, fall = min(
            (
                (moved(end.joints, onto if height < transfer.block_below_tip else ()), self.fall_s(height))
                for end, height in zip(ends, self.heights.lowers)
            ),
            key=sum,
        )
        return ends, motion, fall


@dataclass(frozen=True)
class Exchange:
    """A handover's rendezvous at the meeting point: both arms' joints there and where each jaw is at the
    block's top over its grasp, with the times the exchange cannot do without."""

    giver: NDArray[np.float64]
    giver_out: NDArray[np.float64]  # its jaw out of the hole: passed on the way to its next pick
    receiver: NDArray[np.float64]
    to_receive: float  # the receiver's least time from its starts, in through the block's top, to its grasp
    opening: float  # from the receiver's close to the giver's jaw clear of the wall, its arm still
    let_go: float  # from the receiver's close to the giver's jaw opened and out of the hole


def _bounds(joints: NDArray[np.float64]) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Each joint's least and greatest value over rows of joints."""
    return joints.min(axis=0), joints.max(axis=0)


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
        exchange = bound.exchange(giver, receiver, at[receiver])
        # both at rest, the receiver's jaw entered the block on its final axis, and closes
        to_meet = max(
            bound.lift_to(giver, grasp, pick, exchange.giver), bound.held_on_axis(giver, receiver, pick)
        )
        held_out = started + reach + bound.jaw_close_s + to_meet
        taken = max(free[receiver] + exchange.to_receive, held_out) + bound.jaw_close_s
        ends, place_s, fall = bound.lower(
            receiver,
            place,
            lambda goal, via: through(exchange.receiver, [*via], goal, bound.settings[receiver]),
        )
        times.motion += to_meet
        times.jaw += exchange.opening
        result.arms[receiver].motion += exchange.to_receive + place_s
        result.arms[receiver].jaw += bound.jaw_close_s + fall
        free[giver], at[giver] = taken + exchange.opening, [Start(exchange.giver, exchange.giver_out)]
        free[receiver], at[receiver] = taken + exchange.let_go + place_s, ends
        result.intervals.append((started, free[receiver] + fall))
    return result
