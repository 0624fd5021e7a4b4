"""The reference paper's handover meeting, and which meeting a run takes (`meeting_planner`).

BerkeleyAutomation/FLSpegtransferHO, `FLSPegTransfer_handover.py` and
`motion/dvrkPegTransferMotionHandOver.py`: the giver lifts the block to `height_ready` over its peg and goes
in one cubic to `height_handover` (10 mm higher, z in its own frame), its tool along its base's z at yaw 0
and the block's hole over the handover point (`find_placing_pose` on `pnt_handover`, the mean of pegs 3, 6
and 9 moved −10 mm in y; `go_handover_traj`, `dvrkPegTransferMotionHandOver.py` lines 246 and 265). The
receiver's grasp is the one `pick_block` takes (lines 157–167): at a candidate's point, its tool along its
base's z at the grasp's yaw (`receiver_grasp`, which the look at the held block works out again from what
it sees, `pegbt.behaviours.actions.handover_look`).

Under the paper's protocol with its rest-to-rest cubics (where its robot looks at the block held out,
`/policy/look_at_handover`) the trees and the phase simulator meet as the paper does; otherwise at pegbt's
meeting (`pegbt.behaviours.meeting`), lower, the block coming up its axis onto the meeting point. Which of the
receiver's grasps is taken stays pegbt's (another wall than the giver's, clear of the giver's tool, nearest to
the receiver): the paper's rule (the window of ±70°, then the point farthest to the receiver's side) has the
same intent.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

from pegbt.behaviours.meeting import Meet, Meeting, clear_descent, distance_to, meeting_tip, plan_meeting
from pegbt.behaviours.poses import (
    PLACING_YAW,
    block_axis_top,
    to_arm,
    to_handover,
    transfer_for,
    turned_to_placing,
    yaw_about,
)
from pegbt.behaviours.resources.skills import Skills
from pegbt.errors import PegbtError
from pegbt.frames import apply_rigid, invert_rigid, rigid_transform, yaw_rotation
from pegbt.motion.channel import Channel
from pegbt.motion.handover import handover_meeting_point
from pegbt.motion.ik import solve_ik
from pegbt.motion.placing import STOP_Z, paper_heights
from pegbt.motion.settings import MotionSettings
from pegbt.motion.waypoints import TransferWaypoints
from pegbt.perception.blocks import BlockEstimate
from pegbt.perception.board import BoardEstimate
from pegbt.perception.grasp import Grasp, grasp_options
from pegbt.runconditions import HANDOVER_LOOK_POLICY, protocol_policies
from pegbt.workcell import Workcell

HANDOVER_Z = STOP_Z + 0.010  # m, z in the arm's frame: `height_handover`


def meets_as_paper(skills: Skills) -> bool:
    """Whether a run's handovers meet as the paper's robot met: under its protocol, where its transfers are
    rest-to-rest cubics and it looks at the block held out (`protocol_policies`)."""
    policies = protocol_policies(skills.protocol, skills.condition, "handover")
    return bool(policies.get(HANDOVER_LOOK_POLICY, False))


def meeting_planner(skills: Skills) -> Meet:
    """The meeting a run's handovers take: the paper's (`paper_meeting`) or pegbt's (`plan_meeting`)."""
    return paper_meeting if meets_as_paper(skills) else plan_meeting


def giver_tip(skills: Skills, giver: str, grasp: Grasp, block: BlockEstimate) -> NDArray[np.float64]:
    """Where the giver's tip meets (its arm frame), known before the receiver's grasp is: the paper's
    depends on the giver's `grasp` of `block`, pegbt's on neither."""
    return paper_tip(skills, giver, grasp, block) if meets_as_paper(skills) else meeting_tip(skills, giver)


def giver_carry_waypoints(
    skills: Skills,
    giver: str,
    board: BoardEstimate | None,
    block: BlockEstimate,
    grasp: Grasp,
    tip: NDArray[np.float64],
) -> TransferWaypoints:
    """The giver's carry to the meeting `tip`: the paper's (`paper_carry`) or pegbt's (`to_handover`)."""
    carry = paper_carry if meets_as_paper(skills) else to_handover
    return carry(skills.cell, skills.motion, giver, board, block, grasp, tip)


def paper_tip(skills: Skills, giver: str, grasp: Grasp, block: BlockEstimate) -> NDArray[np.float64]:
    """The giver's tip at the paper's meeting (its arm frame), holding `block` at `grasp`: the tool along the
    base's z at yaw 0 and at `HANDOVER_Z`, the block's axis over the handover point."""
    cell = skills.cell
    up = cell.up_in(giver)
    point = handover_meeting_point(cell, skills.motion)
    point[2] = cell.pegs.top_z  # `pnt_handover`: among the peg tops
    offset = grasp.position - to_arm(cell, giver, block_axis_top(cell, None, block))
    turned = turned_to_placing(offset, yaw_about(grasp.pose[:3, :3], up), up)
    x, y, _ = to_arm(cell, giver, point) + turned
    return rigid_transform(yaw_rotation(PLACING_YAW), [x, y, HANDOVER_Z])


def paper_meeting(
    skills: Skills, giver: str, receiver: str, grasp: Grasp, block: BlockEstimate
) -> Meeting | None:
    """The paper's meeting for `block` held by `giver` at `grasp` (`paper_tip`), with the receiver's grasp
    planned there (`receiver_grasp`); None if it has none or the giver cannot reach it."""
    cell = skills.cell
    tip = paper_tip(skills, giver, grasp, block)
    try:
        q_giver = solve_ik(tip, skills.arm(giver).settings, what="the giver at the paper's meeting point")
    except PegbtError:
        return None
    board_from_giver = cell.arm_to_board(giver)
    block_pose = board_from_giver @ tip @ invert_rigid(board_from_giver @ grasp.pose) @ block.pose
    taken = receiver_grasp(skills, receiver, giver, grasp.candidate, block_pose, q_giver)
    return None if taken is None else Meeting(tip, block_pose, taken)


def paper_carry(
    cell: Workcell,
    motion: MotionSettings,
    arm: str,
    board: BoardEstimate | None,
    block: BlockEstimate,
    grasp: Grasp,
    meeting: NDArray[np.float64],
) -> TransferWaypoints:
    """The giver's carry (`go_handover_traj`): lifted to `height_ready` over its peg, then straight to the
    `meeting` tip pose, where it stops (the last segment has no length)."""
    up = cell.up_in(arm)
    pick = paper_heights(transfer_for(cell, motion, arm, board, block, grasp), "handover", up)
    tolerance = motion.transfer.channel_tolerance
    return TransferWaypoints(
        np.stack([pick.poses[0], pick.poses[1], meeting, meeting]),
        pick.approach,
        pick.pick,
        Channel(meeting[:3, 3], -up, 0.0, tolerance, floor=False),
        pick.upright,
    )


def receiver_grasp(
    skills: Skills,
    receiver: str,
    giver: str,
    giver_candidate: int,
    block_pose: NDArray[np.float64],
    q_giver: NDArray[np.float64],
) -> Grasp | None:
    """The receiver's grasp of a block at `block_pose` (board frame, tilted as it hangs) held by `giver`
    (its joints `q_giver`) by candidate `giver_candidate`: at the candidate's point, the tool upright at
    its yaw, as `pick_block` goes (`euler_to_quaternion([rot, 0, 0])`); on another wall than the giver's,
    reachable, its descent from `receiver_wait_above` keeping `grasp_clearance` of the giver's tool; the
    nearest to the receiver. None if there is none."""
    cell = skills.cell
    edges = cell.block.grasp_candidates.edge
    selector = skills.selectors[receiver]
    options = [
        _upright(cell, option, block_pose)
        for option in grasp_options(block_pose, receiver, cell)
        if abs(option.yaw) <= selector.yaw_window and edges[option.candidate] != edges[giver_candidate]
    ]
    if not options:
        return None
    reachable = np.asarray(selector.reachable(np.array([option.pose for option in options])), dtype=bool)
    return next(
        (
            option
            for option in sorted(
                (option for option, ok in zip(options, reachable) if ok),
                key=lambda option: distance_to(cell, receiver, option),
            )
            if clear_descent(skills, receiver, option, giver, q_giver)
        ),
        None,
    )


def _upright(cell: Workcell, option: Grasp, block_pose: NDArray[np.float64]) -> Grasp:
    """`option` as `pick_block` takes it: `grasp_depth` down the base's z from the candidate's point on the
    (tilted) top face (`offset_grasp` is along the robot's z), the tool along the base's z at the option's
    yaw (`euler_to_quaternion([rot, 0, 0])`)."""
    local = cell.block.grasp_candidates.positions[option.candidate] - [0.0, 0.0, cell.block.grasp_depth]
    tip = to_arm(cell, option.arm, apply_rigid(block_pose, local)) - [0.0, 0.0, cell.block.grasp_depth]
    pose = rigid_transform(yaw_rotation(option.yaw), tip)
    return Grasp(
        option.arm, option.candidate, pose, option.yaw, apply_rigid(cell.arm_to_board(option.arm), tip)
    )
