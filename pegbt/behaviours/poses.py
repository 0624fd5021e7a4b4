"""From what perception saw (board frame) to where an arm's tool goes (that arm's base frame).

The board frame has z pointing down into the board; each arm's frame has z up. Peg tops come from the
registered board when there is one (measured), else from the work cell (modelled). A block lying on the
board, off every peg, is treated as if it sat on a peg at its own position: its top is at the same
height, and it is lifted the same way.
"""

from __future__ import annotations

import math
from typing import NamedTuple

import numpy as np
from numpy.typing import ArrayLike, NDArray

from pegbt.frames import apply_rigid, rigid_transform
from pegbt.motion.channel import Channel, Upright
from pegbt.motion.settings import MotionSettings
from pegbt.motion.waypoints import (
    TransferWaypoints,
    placement_waypoints,
    tool_down_rotation,
    transfer_waypoints,
)
from pegbt.perception.blocks import BlockEstimate, stack_level
from pegbt.perception.board import BoardEstimate
from pegbt.perception.grasp import Grasp
from pegbt.workcell import Workcell

UP_BOARD = np.array([0.0, 0.0, -1.0])
APPROACH_CLEAR_ABOVE_PEG_TOP = 0.002  # m: an approaching jaw is on the block's axis from this high down
# m: a carry to the handover point comes up the block's final axis onto it from this far below: the block is
# then on that axis for its last 0.11-0.20 s, when the receiver's jaw may come down onto it (`await_meeting`);
# arriving from above it came in sideways until its last 0.07-0.12 s, and the receiver landed 0.13-0.24 s late
HANDOVER_RISE = 0.0005
# rad: the paper's robot places every block with its tool at roll 0, the block turned with it
# (BerkeleyAutomation/FLSpegtransferHO, `vision/GraspingPose3D.py` `find_placing_pose`: `placing_pose = [0.0] + ...`)
PLACING_YAW = 0.0
MIN_RISE = 0.005  # m: an approach rises at least this much before it moves over
# m off the axis per m risen, leaving a held block's hole once the jaw's tips are clear of its top (45°)
EXIT_WIDENING = 1.0
# m: a receiver's way to wait above its handover grasp comes down onto that pose from this far above, along
# the line its descent onto the grasp goes on down (`clear_descent` of `pegbt.behaviours.actions.handover`)
WAIT_ARRIVAL = 0.002


def peg_top_board(cell: Workcell, board: BoardEstimate | None, peg: int) -> NDArray[np.float64]:
    """Top centre of `peg` in the board frame: measured if the board was registered, else modelled."""
    return (
        (board.peg_tops[peg] if board is not None and board.ok else cell.pegs.tops[peg]).astype(float).copy()
    )


def block_axis_top(cell: Workcell, board: BoardEstimate | None, block: BlockEstimate) -> NDArray[np.float64]:
    """Where the block's axis crosses the peg-top height, board frame: its peg's top, or above it on the board;
    for a block resting on another (a stack), that much higher, so it is grasped and lifted as if its peg
    were one block taller."""
    if block.peg is not None:
        top = peg_top_board(cell, board, block.peg)
    else:
        top = np.array([block.position[0], block.position[1], cell.pegs.top_z])
    top[2] -= stack_level(block, cell) * cell.block.height  # board z points down
    return top


def to_arm(cell: Workcell, arm: str, point_board: ArrayLike) -> NDArray[np.float64]:
    """A point in the board frame expressed in `arm`'s base frame, where its motions are planned."""
    return apply_rigid(cell.board_to_arm(arm), point_board)


def yaw_about(rotation: NDArray[np.float64], up: NDArray[np.float64]) -> float:
    """The yaw with `tool_down_rotation(yaw, up) == rotation` for a tool pointing down along `up`."""
    untilted = tool_down_rotation(0.0, up).T @ rotation
    return math.atan2(untilted[1, 0], untilted[0, 0])


def tool_pose(position: ArrayLike, yaw: float, up: NDArray[np.float64]) -> NDArray[np.float64]:
    """A tip pose at `position` (arm frame), tool pointing down along −`up`, turned by `yaw`."""
    return rigid_transform(tool_down_rotation(yaw, up), position)


class Pick(NamedTuple):
    """Where a transfer takes a block, arm frame: the top of the block's axis, the tip's offset from it and
    the tool's yaw about the pegs' axis."""

    top: NDArray[np.float64]
    offset: NDArray[np.float64]
    yaw: float


def pick_of(
    cell: Workcell, arm: str, board: BoardEstimate | None, block: BlockEstimate, grasp: Grasp
) -> Pick:
    """The `Pick` of `block` held at `grasp` by `arm`: what every way of carrying it starts from."""
    top = to_arm(cell, arm, block_axis_top(cell, board, block))
    return Pick(top, grasp.position - top, yaw_about(grasp.pose[:3, :3], cell.up_in(arm)))


def turned_to_placing(
    offset: NDArray[np.float64], yaw: float, up: NDArray[np.float64]
) -> NDArray[np.float64]:
    """A tip's `offset` from the held block's axis (arm frame) once a tool at `yaw` has turned to
    `PLACING_YAW` about `up`, the block turning with it; its part across the axis."""
    turned = tool_down_rotation(PLACING_YAW, up) @ tool_down_rotation(yaw, up).T @ offset
    return turned - (turned @ up) * up


def placing_point(
    cell: Workcell,
    arm: str,
    board: BoardEstimate | None,
    place_peg: int,
    offset: NDArray[np.float64],
    yaw: float,
) -> NDArray[np.float64]:
    """Where the paper's robot puts the tip over `place_peg` (arm frame): the peg's top and the tip's `offset`
    from the held block's axis (a tool at `yaw`) turned with the tool to `PLACING_YAW` (`turned_to_placing`;
    FLSpegtransferHO `vision/GraspingPose3D.py` `find_placing_pose`)."""
    top = to_arm(cell, arm, peg_top_board(cell, board, place_peg))
    return top + turned_to_placing(offset, yaw, cell.up_in(arm))


def transfer_for(
    cell: Workcell,
    motion: MotionSettings,
    arm: str,
    board: BoardEstimate | None,
    block: BlockEstimate,
    grasp: Grasp,
    place_peg: int | None = None,
    turn_to_placing: bool = False,
) -> TransferWaypoints:
    """The transfer of `block`, held at `grasp`, onto `place_peg`: the block keeps its yaw, so the tool
    keeps its yaw and its offset from the block's axis; with `turn_to_placing`, the tool turns to
    `PLACING_YAW` on the way and the block with it (`turned_to_placing`), as the paper's robot places.
    Without `place_peg`, only the pick side (grasp, approach, lifted) is meaningful: the block would be put
    back where it is."""
    pick = pick_of(cell, arm, board, block, grasp)
    up = cell.up_in(arm)
    place_top = pick.top if place_peg is None else to_arm(cell, arm, peg_top_board(cell, board, place_peg))
    turned = turned_to_placing(pick.offset, pick.yaw, up) if turn_to_placing else pick.offset
    return transfer_waypoints(
        pick.top,
        place_top,
        pick_offset=pick.offset,
        place_offset=turned,
        pick_yaw=pick.yaw,
        place_yaw=PLACING_YAW if turn_to_placing else pick.yaw,
        up=up,
        heights=motion.transfer,
    )


def height_above_pegs(cell: Workcell, arm: str, tip_arm: ArrayLike) -> float:
    """How far a tip (arm frame) is above the peg tops, along the pegs' axis."""
    tip_board = apply_rigid(cell.arm_to_board(arm), tip_arm)
    return float((tip_board[2] - cell.pegs.top_z) * UP_BOARD[2])


def approach_for(
    cell: Workcell,
    motion: MotionSettings,
    arm: str,
    start: NDArray[np.float64],
    pick: TransferWaypoints,
    out_of: float = 0.0,
) -> TransferWaypoints:
    """The approach from a tool at `start` (tip pose, arm frame; low among the pegs, having just let go of
    a block) to the grasp of `pick`, shaped like a transfer so the same planner serves: rise straight up
    to the transfer height (at least `MIN_RISE`), move over the grasp, descend onto it along the
    block's axis. The descent is a channel from just above the peg tops down: the open jaw comes down
    around the block's wall. With `out_of`, the jaw starts in the hole of a block the other arm holds (a
    giver that just handed it over): it leaves along the pegs' axis until `out_of` up, then the transit's
    own clearance applies (a channel that is no floor), in one motion with the rest. That channel widens
    from where the jaw's tips (`jaw_radius` round, `grasp_depth` deep) are the channel's tolerance over the
    block's top: the released jaw straddles the wall with about that tolerance to spare (`jaw_release`), so
    a tip off the axis by more is over the wall, and the funnel keeps it that tolerance and as much again as
    it is beyond the spare above the top (`EXIT_WIDENING`)."""
    heights = motion.transfer
    up = cell.up_in(arm)
    rise = max(heights.transfer_height_above_peg_top - height_above_pegs(cell, arm, start[:3, 3]), MIN_RISE)
    risen = start.copy()
    risen[:3, 3] += (out_of or rise) * up
    grasp = pick.poses[0][:3, 3]
    descent = heights.block_top_below_peg_top + heights.grasp_depth + APPROACH_CLEAR_ABOVE_PEG_TOP
    exit_hole = (
        Channel(
            start[:3, 3],
            up,
            out_of,
            heights.channel_tolerance,
            floor=False,
            widens_from=heights.grasp_depth + cell.tool.jaw_radius + heights.channel_tolerance,
            widening=EXIT_WIDENING,
        )
        if out_of
        else None
    )
    return TransferWaypoints(
        poses=np.stack([start, risen, pick.poses[1], pick.poses[0]]),
        approach=pick.approach,
        pick=exit_hole,  # nothing is held: the tool is free to leave, out of a hole first
        place=Channel(grasp, up, descent, heights.channel_tolerance),
        upright=pick.upright,
    )


def out_to_wait(
    cell: Workcell,
    motion: MotionSettings,
    arm: str,
    start: NDArray[np.float64],
    wait: NDArray[np.float64],
    over: float,
) -> TransferWaypoints:
    """A receiver's way from a tool at `start` (tip pose, arm frame; low among the pegs, its jaw just opened
    on the block it placed) to `wait` (tip pose, in the air above its next handover grasp), in one motion:
    out along the pegs' axis, a funnel (`EXIT_WIDENING`) from where the jaw's tips (`jaw_radius` round) clear
    the peg tops by the channel's tolerance, up to `WAIT_ARRIVAL` over the waiting pose, and down onto it
    along its axis, the transit above that (its waypoints `over` higher still). Stopping straight above the
    peg first, this way took 1.16 s and the receiver reached its waiting pose late in 3 of seed 1000's 12
    handovers (docs/internals/motion.md)."""
    heights = motion.transfer
    up = cell.up_in(arm)
    depth = -height_above_pegs(cell, arm, start[:3, 3])
    way_out = Channel(
        start[:3, 3],
        up,
        float((wait[:3, 3] - start[:3, 3]) @ up) + WAIT_ARRIVAL,
        heights.channel_tolerance,
        floor=False,
        widens_from=max(depth + cell.tool.jaw_radius + heights.channel_tolerance, 0.0),
        widening=EXIT_WIDENING,
    )
    lifted, above = start.copy(), wait.copy()
    lifted[:3, 3] += (way_out.clear + over) * up
    above[:3, 3] += (WAIT_ARRIVAL + over) * up
    return TransferWaypoints(
        poses=np.stack([start, lifted, above, wait]),
        approach=None,
        pick=way_out,
        place=Channel(wait[:3, 3], up, WAIT_ARRIVAL, heights.channel_tolerance),
        upright=Upright(up, heights.upright_tilt),
    )


def to_handover(
    cell: Workcell,
    motion: MotionSettings,
    arm: str,
    board: BoardEstimate | None,
    block: BlockEstimate,
    grasp: Grasp,
    meeting: NDArray[np.float64],
) -> TransferWaypoints:
    """The giver's carry: lift the block off its peg as in a transfer, then over to `HANDOVER_RISE` below
    the `meeting` tip pose (arm frame) and up the block's final axis onto it: a channel pointing down, which
    is no floor (the transit keeps above the start peg's clearing height alone) and which the tip, once on
    it, never leaves upwards (the block rises into the receiver's open jaw, never past its place)."""
    pick = transfer_for(cell, motion, arm, board, block, grasp)
    up = cell.up_in(arm)
    below = meeting.copy()
    below[:3, 3] -= HANDOVER_RISE * up
    tolerance = motion.transfer.channel_tolerance
    return TransferWaypoints(
        np.stack([pick.poses[0], pick.poses[1], below, meeting]),
        pick.approach,
        pick.pick,
        Channel(meeting[:3, 3], -up, HANDOVER_RISE, tolerance, floor=False),
        pick.upright,
    )


def from_handover(
    cell: Workcell,
    motion: MotionSettings,
    arm: str,
    board: BoardEstimate | None,
    grasp: Grasp,
    block_pose: NDArray[np.float64],
    place_peg: int,
    turn_to_placing: bool = False,
) -> TransferWaypoints:
    """The receiver's placement: from its grasp of the block held in the air (`block_pose`, board frame)
    over peg `place_peg` and down onto it, the block keeping its yaw, or, with `turn_to_placing`, turned
    with the tool to `PLACING_YAW` (`transfer_for`)."""
    up = cell.up_in(arm)
    offset, yaw = _handed_hold(cell, arm, grasp, block_pose)
    return placement_waypoints(
        grasp.pose,
        to_arm(cell, arm, peg_top_board(cell, board, place_peg)),
        place_offset=turned_to_placing(offset, yaw, up) if turn_to_placing else offset,
        place_yaw=PLACING_YAW if turn_to_placing else yaw,
        up=up,
        heights=motion.transfer,
    )


def handed_placing_point(
    cell: Workcell,
    arm: str,
    board: BoardEstimate | None,
    grasp: Grasp,
    block_pose: NDArray[np.float64],
    place_peg: int,
) -> NDArray[np.float64]:
    """`placing_point` for a receiver holding a block handed to it at `grasp` (the block at `block_pose`,
    board frame)."""
    return placing_point(cell, arm, board, place_peg, *_handed_hold(cell, arm, grasp, block_pose))


def _handed_hold(
    cell: Workcell, arm: str, grasp: Grasp, block_pose: NDArray[np.float64]
) -> tuple[NDArray[np.float64], float]:
    """A receiver's tip offset from the handed block's axis point (arm frame) and its tool's yaw."""
    offset = grasp.position - to_arm(cell, arm, block_pose[:3, 3])
    return offset, yaw_about(grasp.pose[:3, :3], cell.up_in(arm))
