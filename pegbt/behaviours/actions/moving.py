"""Arm motions after the grasp: the transfer itself (lift, carry, lower onto the goal peg), rising
straight up, and parking an arm out of the camera's view.

Every motion that starts low among the pegs first rises straight up to the transfer height, so a tool
never sweeps sideways through pegs and blocks.
"""

from __future__ import annotations

from functools import partial

from pegbt.behaviours.actions.grasping import approach_plan
from pegbt.behaviours.base import RESOURCES, MotionLeaf, arm_param, keep_apart_param, key_param, peg_param
from pegbt.behaviours.motion import CarryLeaf, above_pegs_first, carry_params
from pegbt.behaviours.poses import tool_pose, transfer_for
from pegbt.executive.params import Param
from pegbt.executive.registry import behaviour
from pegbt.motion.ik import solve_ik
from pegbt.motion.kinematics import forward_kinematics
from pegbt.motion.trajectory import Trajectory
from pegbt.motion.waypoints import TransferWaypoints
from pegbt.perception.blocks import block_on_peg

MAX_RISE = 0.165  # m: the PSM's whole insertion travel (0.08-0.245 m, skills/psm.yaml)


@behaviour(
    "transfer",
    "lift the held block off its peg, carry it over peg `place` and lower it onto the peg (one trajectory: "
    "SQP-optimised or rest-to-rest cubics, as the condition says); fails at once if the block slips from "
    "the jaw; writes the plan's duration to `plan_s`",
    params=carry_params(
        peg_param("place", "goal peg"),
        key_param("grasp", "read", "the grasp holding the block"),
        key_param("block", "read", "the block held"),
        Param(
            "then",
            dict,
            "the transfer that follows with this arm (a loop's next item: its `pick`), whose approach is "
            "planned while this carry plays, onto the grasp `select_grasp` will choose; {}: none",
            default={},
        ),
    ),
    reads=("/board", "/blocks"),
    resources=RESOURCES,
)
class Transfer(CarryLeaf):
    """Planned early, while the approach plays, when that approach knew this transfer's goal peg
    (`approach`); once sent, it plans the approach of the next transfer (`then`) from where it ends."""

    def waypoints(self) -> TransferWaypoints:
        return transfer_for(
            self.skills.cell,
            self.skills.motion,
            self.param("arm"),
            self.read("/board"),
            self.get("block"),
            self.get("grasp"),
            int(self.param("place")),
        )

    def inputs(self) -> tuple[object, ...]:
        return (self.read("/board"), self.get("block"), self.get("grasp"), int(self.param("place")))

    def started(self, trajectories: list[Trajectory]) -> None:
        super().started(trajectories)
        pick = self.param("then").get("pick")
        if not isinstance(pick, int):
            return
        arm, board = self.param("arm"), self.read("/board")
        block = block_on_peg(self.read("/blocks"), pick)
        grasp = None if block is None or not block.ok else self.skills.selectors[arm].pick(block)
        if block is None or grasp is None:
            return
        motion = self.motion(arm)
        plan = approach_plan(self.skills, arm, motion.start_from(self.client(arm)), board, block, grasp)
        motion.plan_early(self.context.work, (board, block, grasp.candidate), plan)


@behaviour(
    "rise",
    "move `arm` straight up along the pegs' axis by `height` metres (a giver letting go, a tool backing off)",
    params=(
        arm_param(),
        Param("height", float, "how far, m", minimum=0.0, maximum=MAX_RISE),
        keep_apart_param(),
    ),
    resources=RESOURCES,
)
class Rise(MotionLeaf):
    def begin(self) -> None:
        arm = self.param("arm")
        motion = self.motion(arm)
        start = motion.start_from(self.client(arm))
        target = forward_kinematics(start)
        target[:3, 3] += self.param("height") * self.skills.cell.up_in(arm)
        risen = solve_ik(target, motion.settings, what="risen")
        self.move(arm, partial(motion.through, start, [risen], ["risen"]), f"{arm} rising")


@behaviour(
    "park",
    "move `arm` out of the camera's view: rise to the transfer height if low, then to its home pose (tool down)",
    params=(arm_param(), keep_apart_param()),
    resources=RESOURCES,
)
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
