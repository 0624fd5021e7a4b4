"""Arm motions after the grasp: the transfer itself (lift, carry, lower onto the goal peg), rising
straight up, and parking an arm out of the camera's view.

Every motion that starts low among the pegs first rises straight up to the transfer height, so a tool
never sweeps sideways through pegs and blocks.
"""

from __future__ import annotations

from functools import partial

import numpy as np
import py_trees
from numpy.typing import NDArray
from py_trees.common import Status

from pegbt.behaviours.actions.grasping import choose_and_approach_early
from pegbt.behaviours.actions.handover import WayOut, next_block, rise_into_approach
from pegbt.behaviours.base import MotionLeaf
from pegbt.behaviours.motion import CarryLeaf, above_pegs_first, planned_approach, rise, rise_extent
from pegbt.behaviours.poses import pick_of, placing_point, tool_pose, transfer_for
from pegbt.motion.ik import solve_ik
from pegbt.motion.kinematics import tip_position
from pegbt.motion.trajectory import Trajectory
from pegbt.motion.waypoints import TransferWaypoints
from pegbt.perception.blocks import BlockEstimate, block_on_peg
from pegbt.perception.board import BoardEstimate


class Transfer(CarryLeaf):
    """Planned early, while the approach plays, when that approach knew this transfer's goal peg
    (`approach`); once sent, it plans the approach of the next transfer (`then`) from where it ends.

    Under the conditions of `let_go_early` the jaw opens to `jaw_release` as the block comes down onto its
    goal peg, reaching it as the arm stops: it passes the wall (lets go) some 50 ms before, with the tip
    within a millimetre of the drop height and the block's hole 3 mm on the peg (it is on it from 3.2 mm
    above), so `release` finds the jaw open. That holds only where the commands correct the cables'
    error: uncalibrated, a dVRK's tip lags and strays by millimetres its encoders do not show, so a jaw
    opened on the plan's clock may drop the block before its hole is on the peg, and an opening jaw can
    no longer tell that a peg knocked the block out; there the jaw stays closed, watched, until the arm
    is at rest, and `release` opens it. Under the paper's protocol the jaw always stays closed, and a carry
    that stops above the goal peg to look first (`stop_above`) goes at the paper's heights and turns to its
    placing angle (`CarryLeaf`)."""

    def waypoints(self) -> TransferWaypoints:
        return transfer_for(
            self.skills.cell,
            self.skills.motion,
            self.param("arm"),
            self.read("/board"),
            self.get("block"),
            self.get("grasp"),
            int(self.param("place")),
            turn_to_placing=self.turns_to_placing(),
        )

    def placing_point(self) -> NDArray[np.float64]:
        cell, arm, board = self.skills.cell, self.param("arm"), self.read("/board")
        pick = pick_of(cell, arm, board, self.get("block"), self.get("grasp"))
        return placing_point(cell, arm, board, int(self.param("place")), pick.offset, pick.yaw)

    def begin(self) -> None:
        super().begin()
        self.let_go_as_it_lands()

    def inputs(self) -> tuple[object, ...]:
        return (self.read("/board"), self.get("block"), self.get("grasp"), int(self.param("place")))

    def started(self, trajectories: list[Trajectory]) -> None:
        super().started(trajectories)
        pick = self.param("then").get("pick")
        if not isinstance(pick, int) or self.stops_above():  # the look moves the arm before it sets out
            return
        arm, board = self.param("arm"), self.read("/board")
        block = block_on_peg(self.read("/blocks"), pick)
        grasp = None if block is None or not block.ok else self.skills.selectors[arm].pick(block)
        if block is None or grasp is None:
            return
        motion = self.motion(arm)
        start = motion.start_from(self.client(arm))
        plan = partial(planned_approach, self.skills, arm, start, board, block, grasp)
        motion.plan_early(self.context.work, (board, block, grasp.candidate), plan)


# m: the measured tip may be this short of the way out's height (a channel's tolerance)
OUT_TOLERANCE = 0.0005


class Rise(MotionLeaf):
    """Once sent, a giver's rise (`then` the loop's next handover, `handover_to` its receiver) chooses the
    grasp of that next block and plans the approach to it from where the rise ends, while the rise plays
    (`choose_and_approach_early`). Only a giver's rise reads `/blocks` and `/board` (a plain rise needs no
    board seen).

    With a planner, a giver's rise is not a stop: it goes on into the approach of that next block in one
    motion (`rise_into_approach`: up the block's axis, then over), which `approach` takes as its own
    (`ArmMotion.send_ahead`); the rise succeeds as the planned tip passes `height` up, out of the hole, so
    the receiver, told the block is released, carries it off only once the giver's jaw has left it."""

    def setup(self, **kwargs: object) -> None:
        super().setup(**kwargs)
        if self.params["then"] and self.params["handover_to"]:
            for key in ("/board", "/blocks"):
                self.blackboard.register_key(key=key, access=py_trees.common.Access.READ)

    def begin(self) -> None:
        arm = self.param("arm")
        motion = self.motion(arm)
        start = motion.start_from(self.client(arm))
        height = self.param("height")
        self.out_at: float | None = None
        self.out_from: tuple[float, np.ndarray] = (0.0, np.zeros(3))  # the tip's height where it began, up
        self.way: tuple[BoardEstimate | None, BlockEstimate, WayOut] | None = None
        self.extent = height  # how far a rise that is no way out into an approach goes (`rise_extent`)
        block = self.next_block()
        if block is not None and motion.planner is not None:
            board = self.read("/board")
            way = self.early_way((start, height, board, block))
            self.way = (board, block, way)
            planned = partial(
                rise_into_approach,
                self.skills,
                arm,
                self.param("handover_to"),
                start,
                height,
                board,
                block,
                way,
            )
            inputs = (start, height, board, block, way)
            self.move(arm, planned, f"{arm} rising out of the block into its next approach", inputs)
            return
        self.extent = rise_extent(height, self.param("handover_to"), self.param("then"))
        planned = partial(rise, self.skills.cell, motion, arm, start, self.extent)
        self.move(arm, planned, f"{arm} rising", (start, self.extent))

    def default_keep_apart(self) -> float:
        """A giver's way out of the block it handed over (`handover_to`) keeps the tools
        `handover.min_tool_distance` apart: they met closer than `two_arms.keep_apart`."""
        if self.param("handover_to"):
            return self.skills.motion.handover.min_tool_distance
        return super().default_keep_apart()

    def early_way(self, inputs: tuple[object, ...]) -> WayOut:
        """The `WayOut` of the way out planned as the carry was sent, if from these `inputs`, else a fresh
        one: a plan from other inputs may still be running on a worker (a discarded job runs on once
        started) and set its grasp, which would make a plain rise pass for the next approach."""
        early = self.motion(self.param("arm")).early
        if early is not None and isinstance(early.inputs[-1], WayOut):
            way = early.inputs[-1]
            if early.matches((*inputs, way)):
                return way
        return WayOut()

    def next_block(self) -> BlockEstimate | None:
        """The block of the giver's next handover, if it is seen where it should be."""
        if not self.param("then") or not self.param("handover_to"):
            return None
        return next_block(self.param("then"), self.read("/blocks"))

    def started(self, trajectories: list[Trajectory]) -> None:
        arm = self.param("arm")
        if self.way is not None and self.way[2].grasp is not None:
            board, block, way = self.way
            assert way.grasp is not None  # the approach was planned onto it
            self.motion(arm).send_ahead((board, block, way.grasp.candidate))
            self.feedback_message = (
                f"out of the block in {self._out(trajectories[0]):.2f} s, on into the next approach"
            )
            return
        if self.extent > self.param("height"):
            self.feedback_message = f"out of the block in {self._out(trajectories[0]):.2f} s, rising on"
            return
        following = self.next_block()
        if following is not None:
            choose_and_approach_early(
                self.skills,
                self.context.work,
                arm,
                self.param("handover_to"),
                self.read("/board"),
                following,
                self.client(arm),
            )

    def _out(self, planned: Trajectory) -> float:
        """Mark when the planned tip passes `height` up (s from now), for `watch`."""
        up, begun = self.skills.cell.up_in(self.param("arm")), tip_position(planned.q[0])
        heights = (tip_position(planned.q) - begun) @ up
        out = float(planned.t[int(np.argmax(heights >= self.param("height") - 1e-9))])
        self.out_at = self.context.clock.now() + out
        self.out_from = (float(begun @ up), up)
        return out

    def watch(self) -> Status:
        """A way out of a handed-over block that goes on (into the next approach, or up past `height`, see
        `rise_extent`) succeeds once its jaw is out of the block: at the planned time,
        later by as long as the motion stood still on the way (its streamer's stalls and pauses), and once
        the arm's encoders put the tip there too (within `OUT_TOLERANCE`): the arm lags its set-points, and
        the receiver carries the block off as soon as this succeeds."""
        if self.out_at is None:
            return Status.RUNNING
        now = self.context.clock.now()
        out_at = self.out_at + max((motion.handle.paused for motion in self.running), default=0.0)
        if now >= out_at - 1e-9:
            if self._measured_out():
                return Status.SUCCESS
            out_at = now + self.motion(self.param("arm")).settings.control_period
        self.wake_at = out_at if self.wake_at is None else min(self.wake_at, out_at)
        return Status.RUNNING

    def _measured_out(self) -> bool:
        """Whether the measured joints put the tip `height` above where the way out began."""
        start, up = self.out_from
        tip = tip_position(np.asarray(self.client(self.param("arm")).measured_js.position, dtype=float))
        return float(tip @ up) - start >= self.param("height") - OUT_TOLERANCE


class Park(MotionLeaf):
    def begin(self) -> None:
        arm = self.param("arm")
        motion, cell = self.motion(arm), self.skills.cell
        start = motion.start_from(self.client(arm))
        home = tool_pose(motion.settings.home_tip, 0.0, cell.up_in(arm))
        joints = above_pegs_first(cell, self.skills.motion, arm, start, motion.settings)
        joints.append(solve_ik(home, motion.settings, what=f"{arm} home pose"))
        names = [f"stop {i}" for i in range(len(joints) - 1)] + ["home"]
        self.move(arm, partial(motion.through, start, joints, names), f"{arm} parking")

    def started(self, trajectories: list[Trajectory]) -> None:
        self.feedback_message = f"parking in {trajectories[0].duration:.2f} s"
