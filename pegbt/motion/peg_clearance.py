"""How far a tool keeps from the pegs: its shaft, wrist and jaw as the simulator's world sees them
(`tool_segments`, each a segment with the work cell's radius) against each peg, a segment from its top
down to the board with the pegs' radius (`pegbt.sim.world.World._pegs_touched`). The shaft comes down
leaning towards the arm's remote centre, its end (the wrist's pitch axis) about 6 mm above the peg tops and
as far off the tip towards that centre while the jaw grips a resting block: a peg there is under the shaft.
Conservative: the world counts a contact only where the solids' bounding boxes overlap too (a peg's box
starts at its top), this treats a peg's top as rounded by its radius.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike, NDArray

from pegbt.frames import segment_distances
from pegbt.motion.handover import tool_segments
from pegbt.workcell import Workcell


def tool_peg_gap(q: ArrayLike, board_from_arm: NDArray[np.float64], cell: Workcell) -> NDArray[np.float64]:
    """The smallest clearance (m, per configuration of `q` (..., 6)) between the tool and any peg; negative
    where they overlap."""
    tool, pegs = cell.tool, cell.pegs
    tops = np.asarray(pegs.tops, dtype=float)
    feet = np.column_stack([pegs.positions, np.full(len(pegs.positions), cell.board.surface_z)])
    radii = (tool.shaft_radius, tool.wrist_radius, tool.jaw_radius)
    gaps = []
    for (start, end), radius in zip(tool_segments(q, board_from_arm, tool), radii):
        distance = segment_distances(start[..., None, :], end[..., None, :], tops, feet)
        gaps.append(distance.min(axis=-1) - radius - pegs.radius)
    return np.min(np.stack(gaps), axis=0)
