"""The paper's placing angle, for the phase simulator's paper protocol (`registered`, rest-to-rest cubics).

BerkeleyAutomation/FLSpegtransferHO, `vision/GraspingPose3D.py` `find_placing_pose`: the placing angle is
always 0, and the placing point is the grasp point's offset from the block's axis turned by minus the
grasp's angle: the tool turns to roll 0 and the block, held, turns with it about its axis. Roll 0 itself,
not the nearest of the block's three equivalent yaws (the grasp window, ±70° in `find_grasping_pose`,
bounds the turn). All three scripts place so (`FLSPegTransfer_single.py`, `_dual.py`, `_handover.py`);
the turn is made on the way over the goal peg (`transfer_block_traj`'s cubic from the grasp's roll at
`height_ready` over the pick peg to roll 0 at `height_ready` over the goal, `go_place_traj` from the
handover), and `servoing_block` lowers at roll 0, the tool along the base's z, at the heights of
`pegbt.motion.placing`.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

from pegbt.behaviours.poses import (
    PLACING_YAW,
    from_handover,
    handed_placing_point,
    pick_of,
    placing_point,
    transfer_for,
)
from pegbt.motion.placing import paper_heights, straight_down
from pegbt.motion.settings import MotionSettings
from pegbt.motion.waypoints import TransferWaypoints
from pegbt.perception.blocks import BlockEstimate
from pegbt.perception.grasp import Grasp
from pegbt.workcell import Workcell


def paper_transfer(
    cell: Workcell,
    motion: MotionSettings,
    arm: str,
    block: BlockEstimate,
    grasp: Grasp,
    place_peg: int,
    variant: str,
) -> TransferWaypoints:
    """The transfer of `block`, held at `grasp`, onto `place_peg` as `transfer_block` and `servoing_block`
    go: lifted at the grasp's yaw, over the goal peg and down at `PLACING_YAW`, the tip off the peg's axis by
    its offset from the block's turned with the tool, at `variant`'s heights (`paper_heights`,
    `straight_down`); `motion`: the rest of the waypoints' settings."""
    pick = pick_of(cell, arm, None, block, grasp)
    over = placing_point(cell, arm, None, place_peg, pick.offset, pick.yaw)
    waypoints = transfer_for(cell, motion, arm, None, block, grasp, place_peg, turn_to_placing=True)
    return straight_down(paper_heights(waypoints, variant, cell.up_in(arm)), over, PLACING_YAW)


def paper_from_handover(
    cell: Workcell,
    motion: MotionSettings,
    receiver: str,
    grasp: Grasp,
    block_pose: NDArray[np.float64],
    place_peg: int,
) -> TransferWaypoints:
    """The receiver's placement (`go_place`, `servoing_block`): from its `grasp` of the block at `block_pose`
    (board frame) over `place_peg` and down onto it at `PLACING_YAW`, the block turned with the tool, at the
    handover's heights (`paper_heights`, `straight_down`)."""
    up = cell.up_in(receiver)
    over = handed_placing_point(cell, receiver, None, grasp, block_pose, place_peg)
    waypoints = from_handover(
        cell, motion, receiver, None, grasp, block_pose, place_peg, turn_to_placing=True
    )
    return straight_down(paper_heights(waypoints, "handover", up), over, PLACING_YAW)
