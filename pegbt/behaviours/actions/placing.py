"""The reference paper's look at the held block before lowering it (`place_servoing`,
BerkeleyAutomation/FLSpegtransferHO; `pegbt.perception.servo`): with the carry at rest over the goal peg
(`stop_above`), a capture's points in the box over the peg are registered to the block model, and the arm
moves the block's bottom onto the peg's axis by a rest-to-rest move, then lowers it to the drop height.
"""

from __future__ import annotations

from functools import partial

import numpy as np
from numpy.typing import ArrayLike, NDArray
from py_trees.common import Status

from pegbt.behaviours.base import ComputeLeaf
from pegbt.behaviours.motion import CarryLeaf
from pegbt.errors import PegbtError
from pegbt.motion.ik import solve_ik
from pegbt.motion.kinematics import forward_kinematics
from pegbt.motion.placing import DROP_Z
from pegbt.perception.board import BoardEstimate
from pegbt.perception.cloud import Points, open3d_threads
from pegbt.perception.colour import colours_of, red
from pegbt.perception.organised import OrganisedCloud
from pegbt.perception.servo import correction, held_block, in_servo_box, off_the_tool, reach
from pegbt.workcell import Workcell

Look = tuple[NDArray[np.float64], int, str]  # the move (arm frame, m), the points seen, what was seen


def board_points(
    cloud: ArrayLike | OrganisedCloud,
    board: BoardEstimate,
    cell: Workcell,
    tools: dict[str, NDArray[np.float64]],
) -> Points:
    """`cloud`'s finite points in the board's frame that the paper's look keeps: the red ones (`red`), or, in
    a cloud without colour, those off the tools of the arms at the joints of `tools` (arm: joints, as
    planned: `off_the_tool`, which keeps what a tool off its plan shows)."""
    raw = cloud.grid.reshape(-1, 3) if isinstance(cloud, OrganisedCloud) else np.asarray(cloud)
    keep = np.isfinite(raw).all(axis=1)
    seen, rgba = raw[keep], colours_of(cloud)
    if rgba is not None:
        return board.to_board(seen[red(rgba[keep])])  # the mask on the pixels with depth: a Zivid's are few
    points = board.to_board(seen)
    for arm, joints in tools.items():
        points = points[off_the_tool(points, joints, cell.arm_to_board(arm), cell.tool)]
    return points


class FindHeldBlock(ComputeLeaf):
    """`find_block_servo` and `servoing_block`'s correction on `/cloud`'s red points (in a cloud without
    colour, less the points on `arm`'s own tool where its plan put it: `off_the_tool`; a compensated arm's
    encoders read the cables' error away from where its tool is, the plan does not): writes the move to
    `servo`."""

    def inputs(self) -> tuple[object, ...]:
        arm = self.param("arm")
        joints = self.motion(arm).start_from(self.client(arm))  # as planned: where a compensated tool is
        return self.read("/cloud"), self.read("/board"), arm, int(self.param("place")), joints

    def compute(
        self,
        cloud: ArrayLike | OrganisedCloud,
        board: BoardEstimate,
        arm: str,
        peg: int,
        joints: NDArray[np.float64],
    ) -> Look:
        cell = self.skills.cell
        points = board_points(cloud, board, cell, {arm: joints})
        peg_xy = board.peg_tops[:, :2]
        seen = points[in_servo_box(points, peg_xy[peg], cell.board.surface_z)]
        with open3d_threads(1 if self.context.work.inline else None):
            pose, count, why = held_block(self.skills.locator, seen, peg_xy[peg])
        if pose is None:
            return np.zeros(3), count, f"{count} points over peg {peg}, {why}: no correction"
        bottom = pose[:3, 3]
        move = correction(cell.board_to_arm(arm), peg_xy[peg], bottom, count)
        off = 1000 * np.linalg.norm(bottom[:2] - peg_xy[peg])
        return move, count, f"{count} points over peg {peg}: the block's bottom {off:.1f} mm off its axis"

    def finish(self, result: Look) -> Status:
        move, _, seen = result
        self.put("servo", [float(x) for x in move])
        self.feedback_message = f"{seen}; moving {1000 * np.linalg.norm(move):.1f} mm"
        return Status.SUCCESS


class ServoOverPeg(CarryLeaf):
    """From the stop over peg `place`, the arm moves by `servo` (a rest-to-rest move, as the paper's
    `servoing_block`), then lowers the block to the drop height (under the paper's protocol its `height_drop`
    straight down the base's z, the tool along it, `pegbt.motion.placing`; else pegbt's above the peg tops
    along their axis); fails at once if the block slips, as every carry does, and without moving if `servo`
    is longer than a look can ask (`reach` in board x and y)."""

    SEGMENTS = ("carry", "carry", "lower")

    def begin(self) -> None:
        arm, peg = self.param("arm"), int(self.param("place"))
        motion, cell = self.motion(arm), self.skills.cell
        start = motion.start_from(self.client(arm))
        stop = forward_kinematics(start)
        longest = np.sqrt(2) * reach(cell.block)
        try:
            move = np.asarray(self.get("servo"), dtype=float)
        except (TypeError, ValueError):
            move = np.full(3, np.nan)
        if move.shape != (3,) or not np.linalg.norm(move) <= longest:
            raise PegbtError(
                f"{arm}: a move of {move} m over the peg is not a look's (at most {longest:.3f} m)"
            )
        above = stop.copy()
        above[:3, 3] += move
        up, variant = cell.up_in(arm), self.skills.paper_variant
        dropped = above.copy()
        if variant is None:
            drop = self.skills.motion.transfer.drop_height_above_peg_top
            dropped[:3, 3] -= ((above[:3, 3] - cell.peg_tops_in(arm)[peg]) @ up - drop) * up
        else:
            dropped[2, 3] = DROP_Z[variant]  # straight down the base's z, as the turned carry stopped
        self.poses = np.stack([stop, above, above, dropped])
        joints = [solve_ik(pose, motion.settings, what=f"{arm} place") for pose in (above, dropped)]
        self.move(
            arm, partial(motion.through, start, joints, ["servo", "drop"]), f"{arm} servoing and lowering"
        )
