"""The paper's handover poses, for the phase simulator's paper protocol (`registered`, rest-to-rest cubics).

BerkeleyAutomation/FLSpegtransferHO, `FLSPegTransfer_handover.py` and
`motion/dvrkPegTransferMotionHandOver.py`: the giver lifts the block to `height_ready` over its peg and goes
in one cubic to `height_handover` (10 mm higher, z in its own frame), its tool along its base's z at yaw 0
and the block's hole over the handover point (`find_placing_pose` on `pnt_handover`, the mean of pegs 3, 6
and 9 moved −10 mm in y; `go_handover_traj`, `dvrkPegTransferMotionHandOver.py` lines 246 and 265). Only then
does the camera look at the held block (`find_block_servo_handover`) and the receiver's grasp is worked out
from what it sees (`find_grasping_pose_handover`, `pegbt.behaviours.actions.handover_look`, which the trees
run too under `/policy/look_at_handover`); the receiver moves to 3 mm over that grasp point, down
onto it and closes, its tool along its base's z at the grasp's yaw (`pick_block`, lines 157–167); the giver
opens and rises 10 mm (`offset_handover`), and only then does the receiver carry the block away.

pegbt's own handover (`pegbt.behaviours.poses.to_handover`, `pegbt.behaviours.actions.handover`) meets
lower, comes up the block's axis onto the meeting point and sends the receiver to the grasp it planned
from the giver's commanded pose, without a look. Which of the receiver's grasps is taken stays pegbt's
(another wall than the giver's, clear of the giver's tool, nearest to the receiver): the paper's rule (the
window of ±70°, then the point farthest to the receiver's side) has the same intent. The receiver places at
the paper's placing angle, 0 (`paperplacing`). Not reproduced: the paper's cubics are in Cartesian pose
(`dvrkArm.cubic_cartesian`), where these are in joints (docs/guides/sim-to-real.md).
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

from pegbt.behaviours.actions.handover import Meeting
from pegbt.behaviours.actions.handover_look import receiver_grasp
from pegbt.behaviours.poses import (
    PLACING_YAW,
    block_axis_top,
    to_arm,
    transfer_for,
    turned_to_placing,
    yaw_about,
)
from pegbt.behaviours.resources.skills import Skills
from pegbt.errors import PegbtError
from pegbt.frames import invert_rigid, rigid_transform, yaw_rotation
from pegbt.motion.channel import Channel
from pegbt.motion.handover import handover_meeting_point
from pegbt.motion.ik import solve_ik
from pegbt.motion.placing import STOP_Z, paper_heights
from pegbt.motion.settings import MotionSettings
from pegbt.motion.waypoints import TransferWaypoints
from pegbt.perception.blocks import BlockEstimate
from pegbt.perception.grasp import Grasp
from pegbt.workcell import Workcell

HANDOVER_Z = STOP_Z + 0.010  # m, z in the arm's frame: `height_handover`
GIVER_RISE = 0.010  # m: the giver, opened, rises this far before the receiver leaves (`offset_handover`)


def paper_meeting(
    skills: Skills, giver: str, receiver: str, grasp: Grasp, block: BlockEstimate
) -> Meeting | None:
    """The paper's meeting for `block` held by `giver` at `grasp`: the tool along the base's z at yaw 0 and
    at `HANDOVER_Z`, the block's axis over the handover point; the receiver's grasp planned there
    (`receiver_grasp`), None if it has none or the giver cannot reach it."""
    cell = skills.cell
    up = cell.up_in(giver)
    point = handover_meeting_point(cell, skills.motion)
    point[2] = cell.pegs.top_z  # `pnt_handover`: among the peg tops
    offset = grasp.position - to_arm(cell, giver, block_axis_top(cell, None, block))
    turned = turned_to_placing(offset, yaw_about(grasp.pose[:3, :3], up), up)
    x, y, _ = to_arm(cell, giver, point) + turned
    tip = rigid_transform(yaw_rotation(PLACING_YAW), [x, y, HANDOVER_Z])
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
    block: BlockEstimate,
    grasp: Grasp,
    meeting: NDArray[np.float64],
) -> TransferWaypoints:
    """The giver's carry (`go_handover_traj`): lifted to `height_ready` over its peg, then straight to the
    `meeting` tip pose, where it stops (the last segment has no length)."""
    up = cell.up_in(arm)
    pick = paper_heights(transfer_for(cell, motion, arm, None, block, grasp), "handover", up)
    tolerance = motion.transfer.channel_tolerance
    return TransferWaypoints(
        np.stack([pick.poses[0], pick.poses[1], meeting, meeting]),
        pick.approach,
        pick.pick,
        Channel(meeting[:3, 3], -up, 0.0, tolerance, floor=False),
        pick.upright,
    )


def seen_held(
    seen_point: NDArray[np.float64], truth: NDArray[np.float64], noise: NDArray[np.float64]
) -> NDArray[np.float64]:
    """The held block's pose as the look sees it (`find_block_servo_handover` registers the block model to the
    cloud): `truth` (board frame, tilted as it hangs) at `seen_point`, moved by perception's `noise` in
    board x and y."""
    seen = truth.copy()
    seen[:3, 3] = seen_point + [noise[0], noise[1], 0.0]
    return seen
