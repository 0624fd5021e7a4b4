"""The reference paper's look at the held block before it lowers it onto the goal peg.

BerkeleyAutomation/FLSpegtransferHO, `vision/BlockDetection3D.py`'s `find_block_servo` and
`FLSPegTransfer_*.py`'s `place_servoing` / `motion/dvrkPegTransferMotion*.py`'s `servoing_block`: with the
carry at rest over the goal peg, the camera's red points 30–60 mm above the board (`depth_block_servo`)
within ±10 mm of the peg (`mask_around_peg`) are the held block's; the block model is registered to them,
and with fewer than 400 points nothing is corrected. Otherwise the block's bottom on its axis is moved onto
the peg's axis, in the board's plane (`delta_rob[2] = 0` in the arm's frame).

The paper's scripts move the arm by whatever the registration gives. Here a fit whose axis lies where no
block with points in the box could be is not acted on (`plausible`), so a wild registration moves the arm
no farther than a true one could (`reach`); any other fit is moved by, as the paper's was (a fitness
threshold would turn away fits the paper acted on: one seen at 78 % moved the block 3.9 mm).

The paper's colour mask kept the red block's points and dropped the grey tool's (`pegbt.perception.colour`);
a cloud without colour drops the points on the robot's own tool instead, where the robot believes it is
(`off_the_tool`), which keeps the jaw of an arm standing off its plan.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

from pegbt.frames import segment_distances, yaw_pose
from pegbt.motion.kinematics import shaft_end_and_tip
from pegbt.perception.blocks import RESTART_YAWS, BlockLocator, three_fold_yaw
from pegbt.perception.cloud import Points
from pegbt.workcell import BlockModel, ToolGeometry

MIN_POINTS = 400  # `place_servoing`: fewer seen points leave the block uncorrected
HANDED_MIN_POINTS = 100  # `find_block_servo_handover`: fewer seen points are no block held out
BAND = (0.030, 0.060)  # m above the board: `depth_block_servo = [-60, -30]` (mm, pegboard z down)
HALF_BOX = 0.010  # m either side of the peg in board x and y: `mask_around_peg`
HELD_MARGIN = 0.005  # m above the top and below the bottom of a block planned held out: `around_block`
# m beyond the tool's radii: where the robot believes it is (its plan, a registered uncalibrated arm's, a
# compensated arm's), its tool is within a millimetre or two
TOOL_MARGIN = 0.002
STARTS = (-0.004, 0.0, 0.004)  # m: ICP's starts around the top face's centre, in board x and y each


def off_the_tool(
    points: Points, joints: NDArray[np.float64], arm_to_board: NDArray[np.float64], tool: ToolGeometry
) -> NDArray[np.bool_]:
    """Which board-frame `points` lie farther than `TOOL_MARGIN` beyond the tool of an arm at `joints`
    (its shaft, wrist and jaw, as `arm_to_board` places the arm)."""
    shaft_end, tip = shaft_end_and_tip(joints)
    hinge = tip[:3, 3] + tool.jaw_length * tip[:3, 2]
    chain = (
        np.array([np.zeros(3), shaft_end, hinge, tip[:3, 3]]) @ arm_to_board[:3, :3].T + arm_to_board[:3, 3]
    )
    keep = np.ones(len(points), dtype=bool)
    for start, end, radius in zip(
        chain[:-1], chain[1:], (tool.shaft_radius, tool.wrist_radius, tool.jaw_radius), strict=True
    ):
        keep &= segment_distances(points, points, start, end) > radius + TOOL_MARGIN
    return keep


def in_servo_box(points: Points, peg_xy: NDArray[np.float64], surface_z: float) -> NDArray[np.bool_]:
    """Which board-frame `points` lie in `find_block_servo`'s box over the peg at `peg_xy`."""
    above = surface_z - points[:, 2]  # board z runs down
    return (
        (np.abs(points[:, 0] - peg_xy[0]) < HALF_BOX)
        & (np.abs(points[:, 1] - peg_xy[1]) < HALF_BOX)
        & (above > BAND[0])
        & (above < BAND[1])
    )


def around_block(points: Points, pose: NDArray[np.float64], block: BlockModel) -> NDArray[np.bool_]:
    """Which board-frame `points` lie around the block planned held out at `pose` (board frame): within
    `HALF_BOX` of its axis in board x and y, and from its top to its bottom with `HELD_MARGIN` to spare
    either way (the cables' error holds it off its plan). `find_block_servo_handover`
    (`vision/BlockDetection3D.py`) keeps the red points in `depth_block_servo`'s band instead: a cloud
    without colour needs the box to leave out the blocks and pegs below."""
    bottom = pose[:3, 3]
    depth = points[:, 2] - bottom[2]  # board z runs down: the top lies `height` above the bottom
    return (
        (np.abs(points[:, 0] - bottom[0]) < HALF_BOX)
        & (np.abs(points[:, 1] - bottom[1]) < HALF_BOX)
        & (depth > -block.height - HELD_MARGIN)
        & (depth < HELD_MARGIN)
    )


def reach(block: BlockModel) -> float:
    """How far (m, in board x and in board y each) from the peg's axis the axis of a block with points in
    the box can lie: the box's half width and the block's corners' distance from its axis."""
    return HALF_BOX + block.corner_distance


def plausible(block: BlockModel, pose: NDArray[np.float64], axis_xy: NDArray[np.float64]) -> str:
    """Why the fit `pose` (board frame) cannot be the held block whose box is centred on `axis_xy` (a peg's,
    a planned block's), or "" if it can: a wild registration must not move the arm."""
    off = np.abs(pose[:2, 3] - axis_xy)
    if off.max() > reach(block):
        return (
            f"the fit's axis is {1000 * off.max():.1f} mm off the box's, farther than a block with points "
            f"in the box can be ({1000 * reach(block):.1f} mm)"
        )
    return ""


def held_block(
    locator: BlockLocator, seen: Points, axis_xy: NDArray[np.float64], least: int = MIN_POINTS
) -> tuple[NDArray[np.float64] | None, int, str]:
    """The pose (board frame) of the held block registered to the `seen` points (board frame, in a box
    around where it is held: over a peg, `in_servo_box`; at the meeting point, `around_block`) whose axis
    should lie at `axis_xy`, how many there were, and why there is no pose: fewer than `least` (over a peg
    `MIN_POINTS`: the paper corrects nothing) or a fit that cannot be the block's (`plausible`). The box crops the block,
    and ICP from its top face's centre alone settles millimetres off as often as not: it starts from a
    grid around that centre (`STARTS`) at each of the restart yaws, and the best fit is kept."""
    if len(seen) < least:
        return None, len(seen), f"fewer than {least}"
    top = seen[seen[:, 2] < seen[:, 2].min() + locator.settings.top_face_depth]  # board z runs down
    centre = top[:, :2].mean(axis=0)
    z = float(np.median(top[:, 2])) + locator.cell.block.height
    yaw = three_fold_yaw(top[:, :2] - centre, locator.cell.block.edge_directions[0])
    starts = [
        yaw_pose([centre[0] + dx, centre[1] + dy, z], yaw + turn)
        for dx in STARTS
        for dy in STARTS
        for turn in RESTART_YAWS
    ]
    pose = locator.best_fit(seen, starts)[0]
    why = plausible(locator.cell.block, pose, axis_xy)
    return (None if why else pose), len(seen), why


def correction(
    board_to_arm: NDArray[np.float64],
    peg_xy: NDArray[np.float64],
    seen_bottom: NDArray[np.float64],
    points: int,
) -> NDArray[np.float64]:
    """The move (arm frame, m) `servoing_block` adds to the place position: the seen block's bottom on its
    axis (`seen_bottom`, board frame) onto the peg's axis at `peg_xy`, along the board as the robot believes
    its arm stands (`board_to_arm`), its arm-frame z dropped; none when fewer than `MIN_POINTS` were seen."""
    if points < MIN_POINTS:
        return np.zeros(3)
    delta = np.zeros(3)
    delta[:2] = np.asarray(peg_xy, dtype=float) - seen_bottom[:2]
    move = board_to_arm[:3, :3] @ delta
    move[2] = 0.0
    return move
