"""The reference setup's pegboard in each arm's frame (the paper's numbers, from the reference geometry).

Tests and the motion benchmark plan real transfers with these until the workcell module supplies the
calibrated board; nothing else should read them.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

# Peg top centres in the board frame (mm; z points down into the board, peg tops 20.5 mm above it).
PEG_TOPS_BOARD_MM = np.array(
    [
        [15.5, 14.6], [43.8, 14.5], [14.3, 32.3], [44.2, 31.8], [14.6, 49.7], [43.5, 49.7],
        [61.3, 21.1], [78.1, 6.5], [94.7, 21.1], [61.3, 42.8], [78.0, 57.2], [94.8, 42.9],
    ]
)
PEG_TOP_Z_BOARD = -0.0205  # m
UP_BOARD = np.array([0.0, 0.0, -1.0])

# arm_from_board transforms of the paper's setup.
ARM_FROM_BOARD = {
    "PSM1": (
        [[-0.9996, -0.0172, -0.0226], [-0.0172, 0.9999, -0.0011], [0.0226, -0.0007, -0.9997]],
        [0.1882, -0.0340, -0.1698],
    ),
    "PSM2": (
        [[-0.9995, 0.0075, 0.0294], [0.0077, 0.9999, 0.0078], [-0.0294, 0.0080, -0.9995]],
        [-0.0717, -0.0367, -0.1616],
    ),
}

# Unilateral task (PSM1): pick peg → place peg.
UNILATERAL_ORDER = ((1, 7), (0, 6), (3, 8), (2, 9), (5, 11), (4, 10), (7, 1), (6, 0), (8, 3), (9, 2), (11, 5), (10, 4))


def peg_tops_board() -> NDArray[np.float64]:
    """Peg top centres (12, 3) in the board frame, metres."""
    return np.column_stack([PEG_TOPS_BOARD_MM / 1000.0, np.full(len(PEG_TOPS_BOARD_MM), PEG_TOP_Z_BOARD)])


def arm_from_board(arm: str) -> NDArray[np.float64]:
    """The 4x4 transform taking board coordinates to `arm`'s base frame. The stored rotations are
    rounded to 4 digits; they are re-orthonormalised so poses built from them are rigid."""
    rotation, translation = ARM_FROM_BOARD[arm]
    u, _, vt = np.linalg.svd(np.asarray(rotation))
    transform = np.eye(4)
    transform[:3, :3] = u @ vt
    transform[:3, 3] = translation
    return transform


def peg_tops(arm: str) -> NDArray[np.float64]:
    """Peg top centres (12, 3) in `arm`'s base frame."""
    T = arm_from_board(arm)
    return peg_tops_board() @ T[:3, :3].T + T[:3, 3]


def up(arm: str) -> NDArray[np.float64]:
    """The pegs' axis ("up", away from the board) in `arm`'s base frame."""
    return arm_from_board(arm)[:3, :3] @ UP_BOARD
