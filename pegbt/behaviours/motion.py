"""What the motion leaves share: `CarryLeaf`, the base of every motion that carries a block (failed at
once when the block slips out of the jaw), the jaw's test of a hold, rising straight up first, and the
approach of a grasp (planned by the leaf that sends it or ahead of it).

Every motion that starts low among the pegs first rises straight up to the transfer height
(`above_pegs_first`), so a tool never sweeps sideways through pegs and blocks.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from functools import partial

import numpy as np
from numpy.typing import NDArray
from py_trees.common import Status

from pegbt.behaviours.base import MotionLeaf, Outgoing, RobotLeaf
from pegbt.behaviours.poses import PLACING_YAW, approach_for, height_above_pegs, transfer_for
from pegbt.behaviours.resources.arm_motion import ArmMotion
from pegbt.behaviours.resources.skills import Skills
from pegbt.motion.handover import jaw_on_wall
from pegbt.motion.ik import solve_ik
from pegbt.motion.kinematics import forward_kinematics, tip_position
from pegbt.motion.limits import ArmSettings
from pegbt.motion.placing import paper_heights, stopped_above, straight_down
from pegbt.motion.settings import MotionSettings
from pegbt.motion.trajectory import Trajectory
from pegbt.motion.waypoints import TransferWaypoints
from pegbt.perception.blocks import BlockEstimate
from pegbt.perception.board import BoardEstimate
from pegbt.perception.grasp import Grasp
from pegbt.workcell import Workcell

LOW = 0.001  # m: a tip more than this below the transfer height rises before moving sideways
SLIP_CHECK = 0.1  # s: how often a transfer looks at the jaw for a slipping block


def rise(
    cell: Workcell, motion: ArmMotion, arm: str, start: NDArray[np.float64], height: float
) -> Trajectory:
    """`arm`'s quickest motion straight up along the pegs' axis by `height` from joints `start` (it is on
    a handover's critical path: the receiver and the giver's next pick wait for it): the same plan
    whether made when the rise begins or early, while the giver holds its block out (`rise` of
    `carry_to_handover`)."""
    target = forward_kinematics(start)
    target[:3, 3] += height * cell.up_in(arm)
    risen = solve_ik(target, motion.settings, what="risen")
    return motion.quickest(start, [risen], ["risen"])


def rise_extent(height: float, handover_to: str, then: dict) -> float:
    """How far a rise by `height` goes: that far, but a giver's after the last handover of its loop
    (`handover_to`, no `then`) as far again, passing `height` at speed: accelerating all the way there and
    braking beyond, the quickest way up to `height` from rest, its jaw is out of the block (and the receiver
    carries it off) 0.21 s after it sets off where a rise stopping there took 0.30. Nothing follows it
    before the arms park: the receiver still carries that block to its peg."""
    return 2.0 * height if handover_to and not then else height


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


def approach_above_clear(skills: Skills, giving: bool) -> float:
    """How far over the clearing height an approach's warm start passes over the pegs: as a carry for a
    handover's giver, lower still with the other arm parked (`Skills.other_arm_parked`), higher where the
    other arm may rest over them (bilateral). The checks hold the same floor whichever it is."""
    sqp = skills.motion.sqp
    if giving:
        return sqp.warm_above_clear
    return sqp.lone_approach_above_clear if skills.other_arm_parked else sqp.approach_above_clear


def planned_approach(
    skills: Skills,
    arm: str,
    start: NDArray[np.float64],
    board: BoardEstimate | None,
    block: BlockEstimate,
    grasp: Grasp,
    *,
    giving: bool = False,
    out_of: float = 0.0,
) -> Trajectory:
    """`arm`'s approach from joints `start` onto `grasp` of `block` (see `Approach`), planned on a worker with
    its waypoints and stops: the tick that sends it, or takes a plan made early for the same inputs, computes
    none of it; what `transfer` plans ahead for the loop's next block. A handover's giver (`giving`) passes
    over the pegs as low as a carry does (`warm_above_clear`): the receiver works above the meeting point
    and its own side's pegs, not over the giver's. `out_of`: it starts in the hole of the block it just
    handed over, which it leaves along the axis by that much first (`approach_for`)."""
    motion, cell = skills.arm(arm), skills.cell
    waypoints = transfer_for(cell, skills.motion, arm, board, block, grasp)
    stops = above_pegs_first(cell, skills.motion, arm, start, motion.settings)
    if motion.planner is not None:
        approach = approach_for(cell, skills.motion, arm, forward_kinematics(start), waypoints, out_of)
        return motion.transfer(approach, above_clear=approach_above_clear(skills, giving))
    names = [f"above the grasp {i}" for i in range(len(stops))] + [
        "over the grasp",
        "just above the block",
        "grasp",
    ]
    poses = [waypoints.poses[1], waypoints.approach, waypoints.poses[0]]
    joints = stops + [solve_ik(pose, motion.settings, what=name) for pose, name in zip(poses, names[-3:])]
    return motion.through(start, joints, names[: len(joints)])


def closing_lead(skills: Skills, jaw_velocity: float) -> float:
    """Seconds before the arm arrives that an open jaw is sent closing for its set-point to pass
    `grip_confirmed_below` under the block's wall (`jaw_on_wall`) as the tip gets there: `grasp` then
    confirms the grip as the tip arrives."""
    transfer = skills.motion.transfer
    return (transfer.jaw_open - jaw_on_wall(skills.cell) + transfer.grip_confirmed_below) / jaw_velocity


class CarryLeaf(MotionLeaf):
    """A motion carrying a held block: planned through `waypoints()` as the condition says, and failed at
    once, with the arm stopped, if the jaw closes past `held_above` (the block slipped out).

    As it finishes, its `log_detail` says which segment of its motion was playing (`SEGMENTS`: from the
    grasp to lifted, on to above the goal, down onto it; by the planned tip's closest pass by each
    waypoint, and the time since the motion was sent less its stalls) and whether the jaw held the block:
    where a block was lost, in the robot's own terms."""

    may_step_back = False
    SEGMENTS = ("lift", "carry", "lower")  # named after the waypoint each segment ends at

    def waypoints(self) -> TransferWaypoints:
        raise NotImplementedError

    def inputs(self) -> tuple[object, ...] | None:
        """What `waypoints()` are made from, to take a plan made early from the same (None: never early)."""
        return None

    def initialise(self) -> None:
        self.log_detail = None
        self.held_above = self.param("held_above")  # raised once the squeeze eases (`ease_grip`)
        self.held_at_let_go: bool | None = None  # the jaw's hold as it began to open on purpose
        self.slipped_before_let_go: str | None = None  # how the jaw showed the block gone by then
        self.segment_ends: tuple[int, int] | None = None  # planned rows where lift and carry end
        self.sent_at = 0.0
        super().initialise()

    def stops_above(self) -> bool:
        """Whether this carry stops at rest over its goal peg, for a look at the held block before it is
        lowered (`stop_above`, as the tree's policy says; a carry without the parameter never does)."""
        return "stop_above" in self.params and bool(self.param("stop_above"))

    def turns_to_placing(self) -> bool:
        """Whether this carry turns the tool, and the block with it, to the paper's placing angle on its way
        over the goal peg (`transfer_for`'s `turn_to_placing`): under the paper's protocol, where it stops
        there to look (`FLSPegTransfer_single.py`, `_dual.py` and `_handover.py` all place at roll 0)."""
        return self.skills.paper_variant is not None and self.stops_above()

    def placing_point(self) -> NDArray[np.float64]:
        """Where the paper's robot puts the tip over the goal peg (arm frame), the block turned with the tool
        to its placing angle (`pegbt.behaviours.poses.placing_point`): for a carry that turns."""
        raise NotImplementedError

    def _stopping_at_place_height(self, waypoints: TransferWaypoints) -> TransferWaypoints:
        """`waypoints` lifted, stopping over the goal peg and lowered at the paper's heights under its
        protocol (`paper_heights`: z in the arm's own frame), as they are under pegbt's; turned to the
        paper's placing angle, stopped and lowered as `servoing_block` goes, over the placing point with the
        tool along the base's z (`straight_down`)."""
        variant = self.skills.paper_variant
        if variant is None:
            return waypoints
        heights = paper_heights(waypoints, variant, self.skills.cell.up_in(self.param("arm")))
        if not self.turns_to_placing():
            return heights
        return straight_down(heights, self.placing_point(), PLACING_YAW)

    def begin(self) -> None:
        arm = self.param("arm")
        waypoints = self.waypoints()
        self.poses = waypoints.poses
        if self.stops_above():  # never the plan made early, which goes on down
            waypoints = self._stopping_at_place_height(waypoints)
            self.poses = waypoints.poses
            planned = partial(_stopped, partial(self.motion(arm).transfer, waypoints))
            self.move(arm, planned, f"{arm} {self.name}, stopping above", None)
            return
        planned = partial(self.motion(arm).transfer, waypoints)
        self.move(arm, planned, f"{arm} {self.name}", self.inputs())

    def let_go_as_it_lands(self) -> None:
        """Under the conditions of `let_go_early`, open the jaw to `jaw_release` as the block comes down onto
        its goal peg, reaching it as the arm stops (see `Transfer`); never under the paper's protocol (its
        robot let go at rest) nor for a carry that stops above the peg to look first."""
        if (
            self.skills.condition not in self.param("let_go_early")
            or self.skills.protocol == "paper"
            or self.stops_above()
        ):
            return
        arm, transfer = self.param("arm"), self.skills.motion.transfer
        opening = (transfer.jaw_release - transfer.jaw_closed) / self.motion(arm).settings.jaw_velocity
        self.move_jaw(arm, transfer.jaw_release, f"{arm} letting go", before_end=opening)

    def started(self, trajectories: list[Trajectory]) -> None:
        planned = trajectories[0]
        duration = planned.duration
        self.put("plan_s", round(duration, 3))
        self.feedback_message = f"planned in {duration:.2f} s ({self.skills.condition})"
        self.sent_at, self.period = self.context.clock.now(), planned.period
        tips = tip_position(planned.q)
        lifted = int(np.argmin(np.linalg.norm(tips - self.poses[1][:3, 3], axis=1)))
        above = lifted + int(np.argmin(np.linalg.norm(tips[lifted:] - self.poses[2][:3, 3], axis=1)))
        self.segment_ends = (lifted, above)

    def segment(self, paused: float) -> str | None:
        """The segment of the motion playing now, `paused` seconds of stalls after it was sent (None before)."""
        if self.segment_ends is None:
            return None
        row = (self.context.clock.now() - self.sent_at - paused) / self.period
        lifted, above = self.segment_ends
        return self.SEGMENTS[0] if row < lifted else self.SEGMENTS[1] if row < above else self.SEGMENTS[2]

    def update(self) -> Status:
        paused = max((motion.handle.paused for motion in self.running), default=0.0)  # a failure stops them
        status = super().update()
        if status != Status.RUNNING:
            held = self.held_at_let_go
            if held is None:
                jaw = self.client(self.param("arm")).jaw.measured_js.position[0]
                held = slip(jaw, self.held_above) is None
            self.log_detail = {"segment": self.segment(paused), "held": held}
        return status

    def jaw_due(self, outgoing: Outgoing) -> None:
        """A jaw opening as the motion ends lets go on purpose: whether the block was still held is read
        now (a jaw already closed past the wall lost it on the way down: `watch` fails as for any slip),
        and no slip is looked for after it, as an opening jaw no longer shows one."""
        self.slipped_before_let_go = slip(
            self.client(self.param("arm")).jaw.measured_js.position[0], self.held_above
        )
        self.held_at_let_go = self.slipped_before_let_go is None

    def watch(self) -> Status:
        if self.held_at_let_go is None:
            slipped = slip(self.client(self.param("arm")).jaw.measured_js.position[0], self.held_above)
        else:
            slipped = self.slipped_before_let_go
        if slipped:
            return self.fail(
                f"the block slipped from {self.param('arm')}'s jaw ({slipped}) during {self.name}"
            )
        if self.held_at_let_go:
            return Status.RUNNING
        if self.wake_at is not None:
            self.wake_at = min(self.wake_at, self.context.clock.now() + SLIP_CHECK)
        return Status.RUNNING


def _stopped(planned: Callable[[], Trajectory]) -> Trajectory:
    """The carry `planned` makes, cut at its stop over the goal peg (planned on a worker, cut there too)."""
    return stopped_above(planned())


def eased_grip(skills: Skills) -> float:
    """The jaw's set-point eased to `grip_confirmed_below` under the block's wall: the grip a lift carries a
    block off its peg with (it starts as the closing set-point passes it), and a giver holds it out with."""
    return jaw_on_wall(skills.cell) - skills.motion.transfer.grip_confirmed_below


def ease_grip(leaf: RobotLeaf, arm: str, held_above: float) -> float:
    """Ease `arm`'s squeeze on its block to `eased_grip`, if it squeezes harder; the `held_above` that
    still sees a slip then: a block slipping out lets the eased jaw close only to that set-point, above
    `held_above`, so half of `grip_confirmed_below` under the wall shows it."""
    eased, jaw = eased_grip(leaf.skills), leaf.client(arm).jaw
    if float(jaw.setpoint_js.position[0]) < eased:
        jaw.move_jp(eased)
    return max(held_above, eased + leaf.skills.motion.transfer.grip_confirmed_below / 2)


def slip(jaw_angle: float, held_above: float) -> str | None:
    """How the jaw shows that its block slipped out (it closed past `held_above`), or None if it still holds it."""
    angle = float(jaw_angle)
    return f"jaw at {math.degrees(angle):.0f}°" if angle <= held_above else None
