"""Grasping: choose the grasp of a located block, approach it with the jaw open, close and check the
hold; and letting go (`release`: over the goal peg, onto which the transfer already lowered the block).

Whether the jaw holds a block is read from the jaw's own encoder: a jaw closing on a block stops at the
block's wall, one closing on nothing goes all the way.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass
from functools import partial

import numpy as np
from py_trees.common import Status

from pegbt.behaviours.actions.handover import handed, plan_carry_to_meeting, plan_meeting_early
from pegbt.behaviours.base import (
    MotionLeaf,
    RobotLeaf,
)
from pegbt.behaviours.motion import closing_lead, planned_approach
from pegbt.behaviours.paper_meeting import giver_tip
from pegbt.behaviours.poses import transfer_for
from pegbt.behaviours.resources.skills import Skills
from pegbt.clock import is_realtime
from pegbt.errors import PegbtError
from pegbt.executive.work import Job, WorkPool
from pegbt.motion.handover import jaw_clear_of_wall
from pegbt.motion.trajectory import Trajectory
from pegbt.perception.blocks import BlockEstimate, block_on_peg, stack_level
from pegbt.perception.board import BoardEstimate
from pegbt.perception.grasp import Grasp
from pegbt.transport import ArmClient, JawClient

SAME_BLOCK = (
    0.005  # m: a block seen this near where the last pick chose one is that block (a miss may nudge it)
)
OPENED = 1e-4  # rad: a jaw's set-point this near its target needs no motion there
STILL = 0.005  # rad between two readings of a jaw's encoder a period apart: stopped (it closes at 0.06)


class SelectGrasp(RobotLeaf):
    """Choosing among the candidates runs off the tick when it plans a handover for each (`handover_to`)."""

    def initialise(self) -> None:
        self.job: Job | None = None
        self.ahead: GraspAhead | None = None

    def act(self) -> Status:
        if self.job is None:
            chosen = self._choose()
            if chosen is not None:
                return chosen
        assert self.job is not None
        if not self.job.done:
            return Status.RUNNING
        return self._picked(self.job)

    def _choose(self) -> Status | None:
        """Find the block and choose its grasp (None: the choice was handed to a worker)."""
        arm, peg = self.param("arm"), int(self.param("peg"))
        blocks: list[BlockEstimate] = self.read("/blocks")
        block = block_on_peg(blocks, peg)
        if block is None and self.param("dropped"):  # a block on another block never belongs there: it fell
            target = self.skills.cell.pegs.positions[peg]
            loose = sorted(
                (b for b in blocks if b.peg is None or stack_level(b, self.skills.cell) > 0),
                key=lambda b: (not b.ok, float(np.linalg.norm(b.position[:2] - target))),
            )
            block = next((b for b in loose if b.ok), None)
            for stray in self.param("strays"):
                block = block or block_on_peg(blocks, stray)
            block = block or next(
                iter(loose), None
            )  # seen but not located reliably: failed below, saying why
        if block is None:
            return self.fail(
                f"no block seen on peg {peg}" + (" nor on the board" if self.param("dropped") else "")
            )
        self.block = block
        self.where = (
            f"peg {block.peg}" + (" (on another block)" if stack_level(block, self.skills.cell) else "")
            if block.peg is not None
            else f"the board at {np.round(block.position[:2] * 1000, 1).tolist()} mm"
        )
        if not block.ok:
            return self.fail(f"the block on {self.where} is not located reliably: {block.reason}")
        receiver = self.param("handover_to")
        selector, avoid = self.skills.selectors[arm], self._failed_candidate(block)
        if not receiver:
            return self._chosen(selector.pick(block, avoid=avoid))
        self.ahead = None if avoid else self._chosen_ahead(arm, receiver, block)
        if self.ahead is None:
            acceptable = partial(handed, self.skills, arm, receiver, block)
            self.job = self.offload(partial(selector.pick, block, avoid=avoid, acceptable=acceptable))
        return None

    def _chosen_ahead(self, arm: str, receiver: str, block: BlockEstimate) -> GraspAhead | None:
        """The choice made ahead for this block and receiver (`choose_and_approach_early`), adopted."""
        motion, board = self.skills.arm(arm), self.read("/board")
        early = motion.early
        if early is None or not isinstance(early.inputs[-1], GraspAhead):
            return None
        ahead = early.inputs[-1]
        job = motion.take_early((board, block, receiver, ahead))
        if job is None:
            return None
        self.job = self.adopt(job)
        ahead.inputs = (board, block)
        return ahead

    def _picked(self, job: Job) -> Status:
        """The grasp a job chose: its own, or one chosen ahead (then its approach, planned with it, is
        left for `approach` to take; if choosing failed there, it is chosen again here)."""
        ahead, self.ahead = self.ahead, None
        if ahead is None:
            return self._chosen(job.result())
        try:
            job.result()
        except PegbtError:
            ahead.grasp = None
        if ahead.grasp is None:
            self.job = None
            return self._choose() or Status.RUNNING
        assert ahead.inputs is not None  # set as the job was adopted
        board, block = ahead.inputs
        self.skills.arm(self.param("arm")).adopt_early((board, block, ahead.grasp.candidate), job)
        return self._chosen(ahead.grasp)

    def _chosen(self, grasp: Grasp | None) -> Status:
        arm, receiver = self.param("arm"), self.param("handover_to")
        if grasp is None:
            return self.fail(
                f"no grasp of the block on {self.where} is within {arm}'s yaw window and reach"
                + (f" and lets {receiver} take it" if receiver else "")
            )
        self.put("block", self.block)
        self.put("grasp", grasp)
        self.feedback_message = (
            f"{arm} grasps the block on {self.where} at candidate {grasp.candidate}, "
            f"yaw {math.degrees(grasp.yaw):.0f}°"
        )
        return Status.SUCCESS

    def _failed_candidate(self, block: BlockEstimate) -> tuple[int, ...]:
        """The candidate chosen last time, if this is a pick again of the same block."""
        if not self.param("another"):
            return ()
        try:
            last_block: BlockEstimate = self.get("block")
            last_grasp = self.get("grasp")
        except KeyError:
            return ()
        if np.linalg.norm(last_block.position[:2] - block.position[:2]) > SAME_BLOCK:
            return ()
        return (last_grasp.candidate,)


@dataclass
class GraspAhead:
    """A giver's grasp chosen ahead of its `select_grasp` (set by the job that chooses it, None until
    then or if none is), and the board and block `select_grasp` found it for."""

    grasp: Grasp | None = None
    inputs: tuple[BoardEstimate | None, BlockEstimate] | None = None


def choose_and_approach_early(
    skills: Skills,
    pool: WorkPool,
    arm: str,
    receiver: str,
    board: BoardEstimate | None,
    block: BlockEstimate,
    client: ArmClient,
) -> None:
    """While a giver's last motion plays, choose its grasp of `block` for `receiver` as `select_grasp` does
    (no candidate to avoid) and plan the approach to it from where that motion ends, in one job made
    early (`ArmMotion.plan_early`): `select_grasp` takes the grasp if its block is the same, and
    `approach` the plan if it is for that grasp."""
    motion = skills.arm(arm)
    start = motion.start_from(client)
    ahead = GraspAhead()
    acceptable = partial(handed, skills, arm, receiver, block)

    def planned() -> Trajectory:
        grasp = skills.selectors[arm].pick(block, acceptable=acceptable)
        if grasp is None:
            raise PegbtError(f"no grasp of the next block lets {receiver} take it")
        ahead.grasp = grasp
        return planned_approach(skills, arm, start, board, block, grasp, giving=True)

    motion.plan_early(pool, (board, block, receiver, ahead), planned)


class Approach(MotionLeaf):
    """With a planner (optimized), from low among the pegs (having just placed a block) or from high up
    (parked): along an SQP-refined spline that moves over the pegs, clear of their tops, and keeps the
    final descent on the block's axis (from high up it is 0.6-0.8 s quicker than the cubics in lockstep).
    Without one: rest-to-rest cubics, rising first if low, stopping above the grasp and just above the
    block so the descent stays straight.

    The jaw opens on the way and narrows to `jaw_at_grasp` as the tip arrives, for `grasp` to close; under
    the conditions of `close_on_arrival` (commands that put the tip within a millimetre of the plan) it closes
    instead, timed as the receiver's `descend_to_grasp` for its set-point to pass `grip_confirmed_below` under
    the wall as the tip arrives (a block on a peg or the board stands still): the simulated jaw grips with
    the tip as deep in the block as at rest, and `grasp` confirms the grip from the encoder as it arrives.

    Once it is sent, the carry that follows in a transfer (the arm's transfer under way, its goal peg), or
    a giver's carry to the handover's meeting point, is planned and pre-compensated while the approach and
    the grasp play: its inputs (board, block, grasp; the meeting tip) are known; `transfer` or
    `carry_to_handover` takes that plan if its own inputs are the same, and checks it as it is sent."""

    closing = False  # whether `begin` sent the jaw closing on arrival

    def begin(self) -> None:
        arm = self.param("arm")
        block, grasp = self.get("block"), self.get("grasp")
        board = self.read("/board")
        start = self.motion(arm).start_from(self.client(arm))
        giving = self.robot.trial.giving(arm) is not None
        plan = partial(planned_approach, self.skills, arm, start, board, block, grasp, giving=giving)
        self.move(arm, plan, f"{arm} approach", (board, block, grasp.candidate))
        transfer, velocity = self.skills.motion.transfer, self.motion(arm).settings.jaw_velocity
        self.move_jaw(arm, transfer.jaw_open, f"{arm} jaw opening")
        self.closing = (
            self.skills.condition in self.param("close_on_arrival") and self.skills.protocol != "paper"
        )
        if self.closing:  # the set-point passes `grip_confirmed_below` under the wall as the tip arrives
            lead = closing_lead(self.skills, velocity)
            self.move_jaw(arm, transfer.jaw_closed, f"{arm} jaw closing on arrival", before_end=lead)
            return
        narrowing = (transfer.jaw_open - transfer.jaw_at_grasp) / velocity
        self.move_jaw(arm, transfer.jaw_at_grasp, f"{arm} jaw narrowing", before_end=narrowing)

    def watch(self) -> Status:
        """Closing on arrival, the approach is over as the arm arrives (it asks to be ticked then, not once
        the jaw's ramp ends): `grasp` confirms the grip as the jaw goes on closing."""
        if not self.closing:
            return Status.RUNNING
        if not any(motion.handle.busy for motion in self.running if not motion.jaw):
            return Status.SUCCESS
        if self.arm_end is not None:
            self.wake_at = self.arm_end if self.wake_at is None else min(self.wake_at, self.arm_end)
        return Status.RUNNING

    def started(self, trajectories: list[Trajectory]) -> None:
        self.feedback_message = f"approaching in {trajectories[0].duration:.2f} s"
        arm = self.param("arm")
        motion, board, block, grasp = (
            self.motion(arm),
            self.read("/board"),
            self.get("block"),
            self.get("grasp"),
        )
        record = self.robot.trial.under_way(arm, placing=True)
        if record is None:
            giving = self.robot.trial.giving(arm)
            if giving is not None:
                plan_carry_to_meeting(
                    self, arm, board, block, grasp, giver_tip(self.skills, arm, grasp, block)
                )
                plan_meeting_early(self, arm, giving.arms.split("→")[1], grasp, block)
            return
        waypoints = transfer_for(self.skills.cell, self.skills.motion, arm, board, block, grasp, record.place)
        motion.plan_early(
            self.context.work, (board, block, grasp, record.place), partial(motion.transfer, waypoints)
        )


class CloseOnBlock(MotionLeaf):
    """Succeeds as soon as the jaw grips (`gripping`): the squeeze goes on to `jaw_closed` while the
    next motion starts; fails once the jaw closed past `held_above` on nothing.

    In real time it compares each encoder reading with the one about a control period before it, and asks
    to be ticked as the next such reading comes (`wake_when`): ticked only every tree period, it would see
    the grip a reading and a tick later than lockstep does."""

    def begin(self) -> None:
        self.last_angle: float | None = None
        self.last_stamp = -math.inf
        self.move_jaw(
            self.param("arm"), self.skills.motion.transfer.jaw_closed, f"{self.param('arm')} jaw closing"
        )

    def watch(self) -> Status:
        jaw = self.client(self.param("arm")).jaw
        measured, realtime = jaw.measured_js, is_realtime(self.context.clock)
        apart = self.motion(self.param("arm")).settings.control_period / 2
        if realtime and measured.stamp < self.last_stamp + apart:  # the reading compared last: nothing new
            self.wake_when = partial(_read_again, jaw, self.last_stamp + apart, self.wake_when)
            return Status.RUNNING
        self.last_stamp = measured.stamp
        if realtime:
            self.wake_when = partial(_read_again, jaw, self.last_stamp + apart, self.wake_when)
        angle, setpoint = float(measured.position[0]), float(jaw.setpoint_js.position[0])
        last, self.last_angle = self.last_angle, angle
        below = self.skills.motion.transfer.grip_confirmed_below
        if last is not None and gripping(last, angle, setpoint, self.param("held_above"), below):
            return self._held(angle)
        if self.wake_at is not None:
            self.wake_at = min(
                self.wake_at,
                self.context.clock.now() + self.motion(self.param("arm")).settings.control_period,
            )
        return Status.RUNNING

    def done(self) -> Status:
        return self._held(float(self.client(self.param("arm")).jaw.measured_js.position[0]))

    def _held(self, angle: float) -> Status:
        arm = self.param("arm")
        holding = angle > self.param("held_above")
        self.put("holding", holding)
        if not holding:
            return self.fail(
                f"{arm}'s jaw closed to {math.degrees(angle):.0f}° on nothing: no block between the jaws"
            )
        self.feedback_message = f"{arm} holds a block (jaw stopped at {math.degrees(angle):.0f}°)"
        return Status.SUCCESS


def _read_again(jaw: JawClient, after: float, then: Callable[[], bool] | None) -> bool:
    """Whether a tick would find a new reading of `jaw` (stamped `after` or later) or `then` holds; a jaw
    that cannot be read is the tick's to report."""
    try:
        return jaw.measured_js.stamp >= after or (then is not None and then())
    except PegbtError:
        return True


def gripping(last: float, angle: float, setpoint: float, held_above: float, below: float) -> bool:
    """Whether a closing jaw grips a block: its encoder stopped (the same `last` and now: a jaw closing
    on nothing moves every period) above `held_above`, with its set-point `below` under it."""
    return angle > held_above and setpoint <= angle - below and abs(angle - last) < STILL


class Release(MotionLeaf):
    """Opens the jaw only as far as lets the block go and the tool rise out of its hole
    (`transfer.jaw_release`): the next approach opens it fully while it moves. A jaw the transfer already
    opened there (`transfer`) is left as it is. With `once_clear` it is done as the jaw's encoder passes
    the angle at which the jaw clears the wall, the opening going on: nothing the arm does next can drag
    the block then, and waiting for the ramp's end would only delay it."""

    def begin(self) -> None:
        arm, angle = self.param("arm"), self.skills.motion.transfer.jaw_release
        self.clear = jaw_clear_of_wall(self.skills.cell)
        setpoint = float(self.client(arm).jaw.setpoint_js.position[0])
        self.clear_at = self.context.clock.now() + max(
            0.0, (self.clear - setpoint) / self.motion(arm).settings.jaw_velocity
        )
        if abs(setpoint - angle) > OPENED:
            self.move_jaw(arm, angle, f"{arm} jaw opening")

    def watch(self) -> Status:
        if not self.param("once_clear"):
            return Status.RUNNING
        arm = self.param("arm")
        if float(self.client(arm).jaw.measured_js.position[0]) >= self.clear:
            return self.done()
        period = self.motion(arm).settings.control_period
        if self.wake_at is not None:  # ticked as the ramp passes the angle, then each control period
            self.wake_at = min(self.wake_at, max(self.clear_at, self.context.clock.now() + period))
        return Status.RUNNING

    def done(self) -> Status:
        self.put("holding", False)
        return Status.SUCCESS
