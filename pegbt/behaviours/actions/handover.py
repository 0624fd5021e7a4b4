"""Handing a block from one arm (the giver) to the other (the receiver), as in the reference setup.

The giver carries the block to the meeting point (the mean of pegs 3, 6 and 9, shifted and raised as
`skills/motion.yaml` says, tool yaw 0); the receiver waits open above its own grasp of the block there,
descends and closes; the giver opens and rises; the receiver carries the block to its goal peg. The tools meet on purpose
here, so these leaves do not keep the arms apart (`keep_apart` 0); the protocol does. The two arms
never call each other: each step is a leaf, and the trees synchronise them through the handover's record
(`pegbt.handover_protocol`, set and tested by the leaves of `actions/handover_protocol.py` and `conditions/handover_protocol.py`).
"""

from __future__ import annotations

import logging
import math
from collections.abc import Callable
from dataclasses import dataclass
from functools import partial

import numpy as np
import py_trees
from numpy.typing import NDArray
from py_trees.common import Status

from pegbt.behaviours.base import (
    ComputeLeaf,
    MotionLeaf,
    Outgoing,
    RobotLeaf,
)
from pegbt.behaviours.meeting import Meeting
from pegbt.behaviours.motion import (
    CarryLeaf,
    above_pegs_first,
    approach_above_clear,
    closing_lead,
    ease_grip,
    eased_grip,
    planned_approach,
    rise,
    rise_extent,
)
from pegbt.behaviours.paper_meeting import giver_carry_waypoints, meeting_planner
from pegbt.behaviours.poses import from_handover, handed_placing_point, out_to_wait
from pegbt.behaviours.protocol_leaf import read_record
from pegbt.behaviours.resources.arm_motion import ArmMotion, EarlyResult, SentMotion
from pegbt.behaviours.resources.skills import Skills
from pegbt.errors import PegbtError
from pegbt.executive.work import Job
from pegbt.handover_protocol import Giver
from pegbt.motion.handover import jaw_on_wall
from pegbt.motion.ik import solve_ik
from pegbt.motion.kinematics import forward_kinematics, tip_position
from pegbt.motion.trajectory import Trajectory, concatenate
from pegbt.motion.waypoints import TransferWaypoints
from pegbt.perception.blocks import BlockEstimate, block_on_peg
from pegbt.perception.board import BoardEstimate
from pegbt.perception.grasp import Grasp

log = logging.getLogger("pegbt.behaviours")


class HandoverPoses(ComputeLeaf):
    """Planning the meeting (IK and a clearance sweep per candidate grasp) runs off the tick; in real time
    it began as the giver's approach was sent (`plan_meeting_early`), and is taken if made from the same
    grasp and block. The giver's carry to it is planned and pre-compensated early (`plan_carry_to_meeting`):
    usually from the approach already, since the meeting tip is fixed; else here, while the giver waits for
    the receiver (`carry_to_handover` takes that plan if its own inputs are the same, and checks it as it is
    sent). The receiver's way to wait above its grasp, planned early from that meeting while it carried its
    last block (`plan_way_to_meeting`), becomes the plan of that grasp (`go_to_handover` takes it)."""

    def act(self) -> Status:
        if self.job is None:
            self.job = self.early_meeting()
        return super().act()

    def early_meeting(self) -> Job[Meeting | None] | None:
        """The meeting computed early from this leaf's inputs, if it was (one from other inputs is dropped)."""
        giver, receiver, grasp, block = self.inputs()
        if giver == receiver:
            return None
        motion = self.motion(receiver)
        early, motion.meeting = motion.meeting, None
        if early is None or not early.matches((giver, grasp, block)):
            if early is not None:
                early.job.discard()
            return None
        return self.adopt(early.job)

    def inputs(self) -> tuple:
        return self.param("arm"), self.param("receiver"), self.get("grasp"), self.get("block")

    def compute(self, giver: str, receiver: str, grasp: Grasp, block: BlockEstimate) -> Meeting | None:
        if giver == receiver:
            return None
        return meeting_planner(self.skills)(self.skills, giver, receiver, grasp, block)

    def finish(self, meeting: Meeting | None) -> Status:
        giver, receiver = self.param("arm"), self.param("receiver")
        if giver == receiver:
            return self.fail(f"{giver} cannot hand a block to itself")
        if meeting is None:
            return self.fail(
                f"{receiver} can reach no grasp of the block at the meeting point that keeps clear of "
                f"{giver}'s tool"
            )
        self.put("meeting", meeting.tip)
        self.put("block_pose", meeting.block_pose)
        self.put("receiver_grasp", meeting.receiver_grasp)
        taken = meeting.receiver_grasp
        tip = meeting.tip[:3, 3]
        self.feedback_message = (
            f"{giver}'s tip meets at {np.round(tip * 1000, 1).tolist()} mm (its frame); {receiver} takes "
            f"candidate {taken.candidate}, yaw {math.degrees(taken.yaw):.0f}°"
        )
        plan_carry_to_meeting(
            self, giver, self.read("/board"), self.get("block"), self.get("grasp"), meeting.tip
        )
        way = self.motion(receiver)
        if way.early is not None and way.early.matches((self.job,)):
            way.adopt_early((taken,), way.early.job)
        return Status.SUCCESS


def plan_meeting_early(
    leaf: RobotLeaf, giver: str, receiver: str, grasp: Grasp, block: BlockEstimate
) -> None:
    """Start computing the handover of `block` held at `grasp` as the giver's approach to it is sent (its
    inputs are known then, the offer comes only once the block is held): `handover_poses` takes it if its
    own inputs are the same, and the receiver plans its way to the meeting from it while it carries its
    last block (`plan_way_to_meeting`). Not in lockstep, where computing takes no time."""
    pool, motion = leaf.context.work, leaf.motion(receiver)
    if pool.inline or (motion.meeting is not None and motion.meeting.matches((giver, grasp, block))):
        return
    if motion.meeting is not None:
        motion.meeting.job.discard()
    job = pool.submit_ahead(meeting_planner(leaf.skills), leaf.skills, giver, receiver, grasp, block)
    motion.meeting = EarlyResult((giver, grasp, block), job)
    if _waits_empty_handed(leaf, receiver):
        plan_way_to_meeting(leaf, receiver, motion.start_from(leaf.client(receiver)))


def _waits_empty_handed(leaf: RobotLeaf, receiver: str) -> bool:
    """Whether `receiver` stands still with nothing in its jaw (parked for a look): it has no carry before
    its way to the meeting (`plan_way_to_meeting`), so that way is planned from where it is now; planned
    only once it began, it was on the critical path of each first handover after a look (74-91 ms,
    2026-11-29). A jaw stopped on a block above its set-point (as `gripping` sees a grip: a carry comes next) or a
    motion under way leaves the way to be planned as that carry is sent."""
    motion = leaf.motion(receiver)
    if motion.early is not None or (motion.active is not None and motion.active.handle.busy):
        return False
    jaw = leaf.client(receiver).jaw
    holding = float(jaw.measured_js.position[0]) - float(jaw.setpoint_js.position[0])
    return holding < leaf.skills.motion.transfer.grip_confirmed_below


def plan_way_to_meeting(leaf: RobotLeaf, receiver: str, start: NDArray[np.float64]) -> None:
    """Start planning the receiver's way from `start` (where the motion just sent ends) to wait above its
    grasp at the meeting being computed early, if one is. The receiver went there only once the giver held
    the block out and the meeting was planned, then planned the way: on the handover's critical path,
    since its way and descent take longer than the giver's carry. `handover_poses` makes it the plan of
    the grasp the meeting gives."""
    motion = leaf.motion(receiver)
    early = motion.meeting
    if early is None:
        return
    planned = partial(_way_from, leaf.skills, motion, receiver, start, early.job)
    motion.plan_early(leaf.context.work, (early.job,), planned)


def _way_from(
    skills: Skills, motion: ArmMotion, arm: str, start: NDArray[np.float64], meeting: Job[Meeting | None]
) -> Trajectory:
    found = meeting.outcome()
    if found is None:
        raise PegbtError(f"{arm} can take the block at no grasp of the meeting point", field="meeting")
    return way_to_wait(skills, motion, arm, start, found.receiver_grasp)


def way_to_wait(
    skills: Skills, motion: ArmMotion, arm: str, start: NDArray[np.float64], grasp: Grasp
) -> Trajectory:
    """The receiver's way from joints `start` to wait `receiver_wait_above` its `grasp`: from low among the
    pegs (over the block it placed) with a planner, one planned motion up and over (`out_to_wait`); else
    time-optimal rest-to-rest moves, rising first if it is low among the pegs."""
    cell = skills.cell
    wait = grasp.pose.copy()
    wait[:3, 3] += skills.motion.handover.receiver_wait_above * cell.up_in(arm)
    stops = above_pegs_first(cell, skills.motion, arm, start, motion.settings)
    if motion.planner is not None and stops:
        over = approach_above_clear(skills, giving=False)
        way = out_to_wait(cell, skills.motion, arm, forward_kinematics(start), wait, over)
        return motion.transfer(way, above_clear=over)
    joints = stops + [solve_ik(wait, motion.settings, what="waiting above the handover grasp")]
    names = [f"stop {i}" for i in range(len(stops))] + ["waiting pose"]
    return motion.quickest(start, joints, names)


def plan_carry_to_meeting(
    leaf: RobotLeaf,
    giver: str,
    board: BoardEstimate | None,
    block: BlockEstimate,
    grasp: Grasp,
    tip: NDArray[np.float64],
) -> None:
    """Start preparing the giver's carry to the meeting `tip` from where its last motion ends (kept if it
    is already being prepared from the same inputs)."""
    motion = leaf.motion(giver)
    waypoints = giver_carry_waypoints(leaf.skills, giver, board, block, grasp, tip)
    motion.plan_early(leaf.context.work, (board, block, grasp, tip), partial(motion.transfer, waypoints))


@dataclass
class WayOut:
    """The grasp of the next block a giver's way out of the block it handed over goes on to (set by the
    job that plans it; None: none, the way out is a plain rise)."""

    grasp: Grasp | None = None


def rise_into_approach(
    skills: Skills,
    arm: str,
    receiver: str,
    start: NDArray[np.float64],
    height: float,
    board: BoardEstimate | None,
    block: BlockEstimate,
    way: WayOut,
) -> Trajectory:
    """A giver's way out of the block it handed over (its jaw in the block's hole at joints `start`): up
    the block's axis by `height`, then on, in the same motion, into the approach of its next `block`, onto
    the grasp `select_grasp` will choose for `receiver` (`way.grasp`); a plain rise if there is none or
    nothing plans it (without a planner: the cubics stop above the pegs first anyway)."""
    motion = skills.arm(arm)
    if motion.planner is not None:
        grasp = skills.selectors[arm].pick(block, acceptable=partial(handed, skills, arm, receiver, block))
        if grasp is not None:
            try:
                planned = planned_approach(
                    skills, arm, start, board, block, grasp, giving=True, out_of=height
                )
            except PegbtError as error:
                log.info("%s: rising alone: %s", arm, error)
            else:
                way.grasp = grasp
                return planned
    return rise(skills.cell, motion, arm, start, height)


def handed(skills: Skills, arm: str, receiver: str, block: BlockEstimate, option: Grasp) -> bool:
    """Whether `receiver` can take `block` from `arm` holding it by `option`."""
    return meeting_planner(skills)(skills, arm, receiver, option, block) is not None


class CarryToHandover(CarryLeaf):
    """With `ease`, it holds the block out with the grip the lift began with (`eased_grip`) from the moment
    it stops at the meeting point: a receiver may take the block within the jaw's ramp up from `jaw_closed`
    (0.06 s), and the giver's opening starts wherever that ramp is. The ramp is sent on the first tick from a
    tree period before it would end as the arm stops, so it is over by then whichever tick it lands on; a
    slip is still seen (`ease_grip`)."""

    SEGMENTS = (
        "lift",
        "carry",
        "carry",
    )  # the last arrives at the meeting point: there is no peg to lower onto

    def initialise(self) -> None:
        self.eased = False
        super().initialise()

    def watch(self) -> Status:
        if self.param("ease") and not self.eased:
            self._ease_when_due()
        return super().watch()

    def _ease_when_due(self) -> None:
        if self.arm_end is None:
            return
        arm, now = self.param("arm"), self.context.clock.now()
        setpoint = float(self.client(arm).jaw.setpoint_js.position[0])
        ramp = max(0.0, eased_grip(self.skills) - setpoint) / self.motion(arm).settings.jaw_velocity
        paused = max(motion.handle.paused for motion in self.running)
        due = self.arm_end + paused - ramp - self.context.period
        if now >= due - 1e-9:
            self.held_above = ease_grip(self, arm, self.held_above)
            self.eased = True
        elif self.wake_at is not None:
            self.wake_at = min(self.wake_at, due)

    def waypoints(self) -> TransferWaypoints:
        return giver_carry_waypoints(
            self.skills,
            self.param("arm"),
            self.read("/board"),
            self.get("block"),
            self.get("grasp"),
            self.get("meeting"),
        )

    def inputs(self) -> tuple[object, ...]:
        return (self.read("/board"), self.get("block"), self.get("grasp"), self.get("meeting"))

    def setup(self, **kwargs: object) -> None:
        super().setup(**kwargs)
        if self.params["then"]:
            self.blackboard.register_key(key="/blocks", access=py_trees.common.Access.READ)

    def started(self, trajectories: list[Trajectory]) -> None:
        """The giver's rise once it lets go (`rise`, 0: none) is planned while it carries the block and
        holds it out: the receiver waits for that rise before it carries the block away. With a planner
        and the loop's next block (`then`), that rise goes on into the approach of the next block
        (`rise_into_approach`), planned here as `rise` will plan it."""
        super().started(trajectories)
        height = self.param("rise")
        if height <= 0:
            return
        arm = self.param("arm")
        motion, end = self.motion(arm), trajectories[0].q[-1].copy()
        giving = self.robot.trial.giving(arm)
        receiver = "" if giving is None else giving.arms.split("→")[1]
        following = next_block(self.param("then"), self.read("/blocks")) if self.param("then") else None
        if giving is None or following is None or motion.planner is None:
            extent = rise_extent(height, receiver, self.param("then"))
            planned = partial(rise, self.skills.cell, motion, arm, end, extent)
            motion.plan_early(self.context.work, (end, extent), planned)
            return
        board, way = self.read("/board"), WayOut()
        way_out = partial(rise_into_approach, self.skills, arm, receiver, end, height, board, following, way)
        motion.plan_early(self.context.work, (end, height, board, following, way), way_out)


def next_block(then: dict, blocks: list[BlockEstimate]) -> BlockEstimate | None:
    """The block of a giver's next handover (`then`, the loop's next item), if it is seen where it should be."""
    pick = then.get("pick")
    block = block_on_peg(blocks, pick) if isinstance(pick, int) else None
    return block if block is not None and block.ok else None


class GoToHandover(MotionLeaf):
    """Planned early, in real time, while the receiver carried its last block (`plan_way_to_meeting`)."""

    def begin(self) -> None:
        arm, grasp = self.param("arm"), self.get("grasp")
        motion = self.motion(arm)
        start = motion.start_from(self.client(arm))
        planned = partial(way_to_wait, self.skills, motion, arm, start, grasp)
        self.move(arm, planned, f"{arm} going to the handover", (grasp,))
        self.move_jaw(arm, self.skills.motion.transfer.jaw_open, f"{arm} jaw opening")

    def started(self, trajectories: list[Trajectory]) -> None:
        """The descent onto the grasp that follows is planned while the receiver goes to wait above it."""
        arm = self.param("arm")
        motion, grasp = self.motion(arm), self.get("grasp")
        motion.plan_early(
            self.context.work, (grasp,), descent(self.skills, motion, trajectories[0].q[-1], grasp)
        )


def descent(
    skills: Skills, motion: ArmMotion, start: NDArray[np.float64], grasp: Grasp, hold: float = 0.0
) -> Callable[[], Trajectory]:
    """The planning of the receiver's descent from joints `start` onto `grasp`, held still `hold` s first:
    time-optimal, since its part below the block's top plays only once the giver holds the block still
    (`await_meeting`)."""
    target = solve_ik(grasp.pose, motion.settings, what="the handover grasp")
    return partial(_held_descent, motion, start, target, hold)


def _held_descent(
    motion: ArmMotion, start: NDArray[np.float64], target: NDArray[np.float64], hold: float
) -> Trajectory:
    moving = motion.quickest(start, [target], ["grasp"])
    rows = round(hold / moving.period)
    if rows < 1:
        return moving
    times = np.arange(rows + 1, dtype=np.float64) * moving.period
    still = np.repeat(start[None], rows + 1, axis=0)
    zeros = np.zeros_like(still)
    return concatenate([Trajectory(times, still, zeros, zeros), moving])


def giver_of(leaf: RobotLeaf, receiver: str) -> str:
    """The other arm: the one bringing the block."""
    return next(name for name in leaf.robot.arms if name != receiver)


def giver_carry(leaf: RobotLeaf, receiver: str) -> SentMotion | None:
    """The giver's motion under way (its carry, once it offered the block), if any."""
    active = leaf.motion(giver_of(leaf, receiver)).active
    return active if active is not None and active.handle.busy else None


def set_off(leaf: RobotLeaf, receiver: str, grasp: Grasp, carry: SentMotion, now: float) -> float:
    """The first clock time from `now` (on the control period) from which the receiver's descent onto
    `grasp` keeps its tip `approach_above_block` above the block's top, as `carry` moves it, until it ends,
    except once the block is within `channel_tolerance` of where it will be held out, sideways: then only
    above its grasp of the block; and no sooner than brings the tip to its grasp before the carry has ended
    by the time the closing jaw meets the wall (`descend_to_grasp` would only narrow it). A carry that stood
    still on the way (`paused`) is that far behind its plan: the block is higher than planned, and a descent
    timed on the plan alone would meet it."""
    motion, cell, giver = leaf.motion(receiver), leaf.skills.cell, giver_of(leaf, receiver)
    descent_plan = descent(leaf.skills, motion, motion.start_from(leaf.client(receiver)), grasp)()
    heights = (tip_position(descent_plan.q) - grasp.pose[:3, 3]) @ cell.up_in(receiver)
    times = carry.sent_at + carry.handle.paused + carry.planned.t
    tips = tip_position(carry.planned.q)
    up, transfer = cell.up_in(giver), leaf.skills.motion.transfer
    above = (tips - tips[-1]) @ up  # the block over where it will be held out
    aside = np.linalg.norm(tips - tips[-1] - np.outer(above, up), axis=1)
    # its jaw may enter the block's hole once the block is within a channel's tolerance of where it will
    # be held, as a tip on a peg's axis (the open jaw has millimetres either side of the wall there)
    clear = np.where(
        aside > transfer.channel_tolerance, cell.block.grasp_depth + transfer.approach_above_block, 0.0
    )
    starts = np.arange(now, times[-1] + descent_plan.period, descent_plan.period)
    later = times[None, :] - starts[:, None]
    tip = np.interp(np.maximum(later, 0.0), descent_plan.t, heights)
    safe = np.all((later < 0.0) | (tip >= clear + above[None, :] - 1e-9), axis=1)
    # nor so soon that its tip arrives before the block is still by the time the closing jaw meets the wall
    # (`descend_to_grasp` would only narrow its jaw): a block coming up its axis lets the descent end early
    settled = times[-1] + transfer.grip_confirmed_below / motion.settings.jaw_velocity - descent_plan.duration
    safe &= starts >= settled - 1e-9
    return float(starts[np.argmax(safe)]) if safe.any() else float(times[-1])


class AwaitMeeting(RobotLeaf):
    """The receiver, waiting above its grasp, begins its descent while the giver's carry still plays: at
    the first moment from which its tip, descending, stays `approach_above_block` above the top of the
    block as the giver's planned carry moves it (it arrives from above) until the carry ends, or, once the
    block is within `channel_tolerance` of where it will be held out sideways (coming down the last
    millimetres, its wall between the open jaws with millimetres to spare either side), only above its
    grasp of the block. The descent is hidden behind the carry as far as that allows: given the set-off
    (`set_off`), among the descents down the same joint line none ends sooner, and the receiver sends it a
    tree period early (the context's `period`), held still until then: the tick that sends it is the last
    before the set-off, where the first after it set it off up to a period late. The jaw closes only on a
    block that is still by the time it meets the wall (`descend_to_grasp`)."""

    def initialise(self) -> None:
        patience = self.params["patience"]
        self.deadline = math.inf if patience is None else self.context.clock.now() + patience
        self.wake_at: float | None = self.deadline
        # (the carry's send time and stalls so far, when to set off)
        self.planned: tuple[tuple[float, float], float] | None = None

    def act(self) -> Status:
        record = read_record(self, self.params["n"])
        now = self.context.clock.now()
        if record.giver is Giver.ARRIVED:
            self.feedback_message = "the giver holds the block out"
            return Status.SUCCESS
        arm = self.param("arm")
        carry = giver_carry(self, arm) if record.giver is Giver.OFFERED else None
        if carry is not None:
            timed_on = (carry.sent_at, carry.handle.paused)
            if self.planned is None or self.planned[0] != timed_on:
                self.planned = (timed_on, set_off(self, arm, self.get("grasp"), carry, now))
            ahead = self.planned[1] - self.context.period
            if now >= ahead - 1e-9:
                end = carry.sent_at + carry.handle.paused + carry.planned.duration
                self.feedback_message = f"the giver arrives in {end - now:.2f} s: descending"
                return Status.SUCCESS
            self.wake_at = min(self.deadline, ahead)
        if now > self.deadline:
            return self.fail(
                f"the giver has not brought the block after {self.params['patience']:g} s ({record})"
            )
        self.feedback_message = f"waiting for the giver to bring the block ({record})"
        return Status.RUNNING


class DescendToGrasp(MotionLeaf):
    """Planned early, while the receiver goes to wait above the grasp (`go_to_handover`); sent ahead of its
    set-off while the giver's carry plays (`await_meeting`), it is planned again, held still until then.
    Once sent, the carry that follows (`carry_from_handover` to the goal peg of the receiver's transfer
    under way) is planned and pre-compensated while the receiver descends, closes and waits for the giver
    to let go.

    The giver holds the block out until the receiver's jaw grips it, so the close is on the handover's
    critical path: the open jaw is sent on as the tip arrives, timed for its set-point to pass
    `grip_confirmed_below` under the wall (`jaw_on_wall`) as the tip gets there, so that `grasp` confirms the
    grip as it arrives: closing if by the time it meets the wall the block is still, held out (handover `n`)
    or at the end of the carry the descent was timed on (the giver says so a tick later), narrowing to
    `jaw_at_grasp` otherwise, as an approach's does. Once the arm has arrived the leaf succeeds while the
    jaw goes on closing; `grasp` confirms the grip. A giver whose block slips meanwhile (its carry stopped)
    finds the receiver not yet closing and fetches it again, as before any close."""

    def begin(self) -> None:
        arm = self.param("arm")
        motion, grasp = self.motion(arm), self.get("grasp")
        start, now = motion.start_from(self.client(arm)), self.context.clock.now()
        offered = read_record(self, self.params["n"]).giver is Giver.OFFERED
        self.carry = giver_carry(self, arm) if offered else None
        hold = 0.0 if self.carry is None else max(0.0, set_off(self, arm, grasp, self.carry, now) - now)
        planned = descent(self.skills, motion, start, grasp, hold)
        self.move(arm, planned, f"{arm} descending onto the grasp", (grasp, hold) if hold else (grasp,))
        lead = closing_lead(self.skills, motion.settings.jaw_velocity)
        self.move_jaw(arm, self.skills.motion.transfer.jaw_at_grasp, f"{arm} jaw narrowing", before_end=lead)
        self.closing = False

    def jaw_due(self, outgoing: Outgoing) -> None:
        if self._block_still_by_the_wall():
            outgoing.jaw_angle = self.skills.motion.transfer.jaw_closed
            outgoing.what = f"{self.param('arm')} jaw closing on the block held out"
            self.closing = True

    def _block_still_by_the_wall(self) -> bool:
        """Whether the giver holds the block out, or its carry to the meeting point will have ended by the
        time the closing jaw meets the wall."""
        said, arm, carry = read_record(self, self.params["n"]).giver, self.param("arm"), self.carry
        if said is Giver.ARRIVED:
            return True
        if said is not Giver.OFFERED or carry is None or self.motion(giver_of(self, arm)).active is not carry:
            return False
        if carry.handle.done:  # ended where it was planned to, the giver not yet ticked to say so
            return True
        jaw = float(self.client(arm).jaw.setpoint_js.position[0])
        meets = (jaw - jaw_on_wall(self.skills.cell)) / self.motion(arm).settings.jaw_velocity
        end = carry.sent_at + carry.planned.duration + carry.handle.paused  # stalls put it off
        return carry.handle.busy and end <= self.context.clock.now() + meets

    def watch(self) -> Status:
        if not self.closing:
            return Status.RUNNING
        if not any(motion.handle.busy for motion in self.running if not motion.jaw):
            return Status.SUCCESS
        if self.arm_end is not None:  # ticked as the arm arrives, not once the jaw's ramp ends
            self.wake_at = self.arm_end if self.wake_at is None else min(self.wake_at, self.arm_end)
        return Status.RUNNING

    def started(self, trajectories: list[Trajectory]) -> None:
        arm = self.param("arm")
        record = self.robot.trial.under_way(arm, placing=True)
        try:
            block_pose = self.get("block_pose")
        except KeyError:
            return
        if record is None:
            return
        motion, board, grasp = self.motion(arm), self.read("/board"), self.get("grasp")
        cell, settings = self.skills.cell, self.skills.motion
        waypoints = from_handover(cell, settings, arm, board, grasp, block_pose, record.place)
        motion.plan_early(
            self.context.work, (board, grasp, block_pose, record.place), partial(motion.transfer, waypoints)
        )


class CarryFromHandover(CarryLeaf):
    """The receiver's carry to its goal peg lets go as the block lands under the conditions of
    `let_go_early`, as a transfer's does, and turns to the paper's placing angle as a transfer does
    (`turns_to_placing`)."""

    def begin(self) -> None:
        super().begin()
        self.let_go_as_it_lands()

    def started(self, trajectories: list[Trajectory]) -> None:
        """The way to the next handover's meeting, if it is being computed, is planned while this carry
        plays."""
        super().started(trajectories)
        plan_way_to_meeting(self, self.param("arm"), trajectories[0].q[-1].copy())

    def waypoints(self) -> TransferWaypoints:
        return from_handover(
            self.skills.cell,
            self.skills.motion,
            self.param("arm"),
            self.read("/board"),
            self.get("grasp"),
            self.get("block_pose"),
            int(self.param("place")),
            turn_to_placing=self.turns_to_placing(),
        )

    def placing_point(self) -> NDArray[np.float64]:
        return handed_placing_point(
            self.skills.cell,
            self.param("arm"),
            self.read("/board"),
            self.get("grasp"),
            self.get("block_pose"),
            int(self.param("place")),
        )

    def inputs(self) -> tuple[object, ...]:
        return (self.read("/board"), self.get("grasp"), self.get("block_pose"), int(self.param("place")))
