"""Block estimates for grasp-selection tests: a block resting on a peg, pushed within its hole's clearance."""

from __future__ import annotations

import math

import numpy as np

from pegbt.perception.blocks import BlockEstimate
from pegbt.workcell import workcell

CELL = workcell()


def everywhere(poses: np.ndarray) -> np.ndarray:
    """A reachability predicate that accepts every pose."""
    return np.ones(len(poses), dtype=bool)


def estimate_at(xy: np.ndarray, yaw: float, peg: int | None) -> BlockEstimate:
    position = np.array([xy[0], xy[1], CELL.board.surface_z])
    return BlockEstimate(position, yaw, peg, fitness=1.0, rmse=0.0003, points=1000, ok=True, reason="")


def off_peg(peg: int, direction_deg: float, offset: float = 0.0015, yaw: float = 0.3) -> BlockEstimate:
    """A block resting on `peg` pushed `offset` towards `direction_deg` (the hole's clearance allows 2 mm)."""
    angle = math.radians(direction_deg)
    return estimate_at(
        CELL.pegs.positions[peg] + offset * np.array([math.cos(angle), math.sin(angle)]), yaw, peg
    )
