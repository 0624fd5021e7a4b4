"""The reference paper's look at the held block before it lowers it onto the goal peg.

BerkeleyAutomation/FLSpegtransferHO, `vision/BlockDetection3D.py`'s `find_block_servo` and
`FLSPegTransfer_*.py`'s `place_servoing` / `motion/dvrkPegTransferMotion*.py`'s `servoing_block`: with the
carry at rest over the goal peg, the camera's red points 30–60 mm above the board (`depth_block_servo`)
within ±10 mm of the peg (`mask_around_peg`) are the held block's; the block model is registered to them,
and with fewer than 400 points nothing is corrected. Otherwise the block's bottom on its axis is moved onto
the peg's axis, in the board's plane (`delta_rob[2] = 0` in the arm's frame).
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

from pegbt.perception.blocks import BlockEstimate, BlockLocator
from pegbt.perception.cloud import Points

MIN_POINTS = 400  # `place_servoing`: fewer seen points leave the block uncorrected
BAND = (0.030, 0.060)  # m above the board: `depth_block_servo = [-60, -30]` (mm, pegboard z down)
HALF_BOX = 0.010  # m either side of the peg in board x and y: `mask_around_peg`


def in_servo_box(points: Points, peg_xy: NDArray[np.float64], surface_z: float) -> NDArray[np.bool_]:
    """Which board-frame `points` lie in `find_block_servo`'s box over the peg at `peg_xy`."""
    above = surface_z - points[:, 2]  # board z runs down
    return (
        (np.abs(points[:, 0] - peg_xy[0]) < HALF_BOX)
        & (np.abs(points[:, 1] - peg_xy[1]) < HALF_BOX)
        & (above > BAND[0])
        & (above < BAND[1])
    )


def held_block(
    locator: BlockLocator, points: Points, peg_xy: NDArray[np.float64], peg: int
) -> tuple[BlockEstimate | None, int]:
    """The held block registered to the `points` (board frame) in the box over peg `peg` (of the pegs at
    `peg_xy`), and how many there were; None when fewer than `MIN_POINTS` (the paper corrects nothing)."""
    seen = points[in_servo_box(points, peg_xy[peg], locator.cell.board.surface_z)]
    if len(seen) < MIN_POINTS:
        return None, len(seen)
    return locator.register(seen, peg_xy), len(seen)


def correction(
    board_to_arm: NDArray[np.float64], peg_xy: NDArray[np.float64], seen_bottom: NDArray[np.float64], points: int
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
