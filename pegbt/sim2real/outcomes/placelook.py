"""The reference paper's look at the held block before it lowers it onto the goal peg.

BerkeleyAutomation/FLSpegtransferHO, `FLSPegTransfer_single.py` / `FLSPegTransfer_dual.py` /
`FLSPegTransfer_handover.py` (`move_blocks`, `place_servoing`) and `motion/dvrkPegTransferMotion*.py`
(`transfer_block_traj`, `servoing_block`): the carry stops at rest at `height_ready` (−0.120 m in the arm's
frame) over the goal peg; the camera captures; `vision/BlockDetection3D.py`'s `find_block_servo` keeps the
red points 30–60 mm above the board (`depth_block_servo`) within ±10 mm of the peg (`mask_around_peg`) and
registers the block model `img/block_cr.pcd` (origin on the hole's axis at the top face, z 0–14.9 mm down
to the bottom) to them; with fewer than 400 points nothing is corrected. Otherwise the block's bottom on its
axis (`T·[0, 0, 15]`) is moved onto the peg's axis (`p_peg`, the peg's point 5 mm up: only x, y count, since
`delta_rob[2] = 0` in the arm's frame): the arm moves by that at `height_ready`, then goes down to
`height_drop` and opens its jaw.
"""

from __future__ import annotations

from dataclasses import replace
from functools import cache

import numpy as np
import open3d as o3d
from numpy.typing import NDArray

from pegbt.motion.settings import MotionSettings
from pegbt.sim.camera import DepthCamera
from pegbt.sim.world import World
from pegbt.workcell import workcell

MIN_POINTS = 400  # `place_servoing`: fewer seen points leave the block uncorrected
BAND = (0.030, 0.060)  # m above the board: `depth_block_servo = [-60, -30]` (mm, pegboard z down)
HALF_BOX = 0.010  # m either side of the peg in board x and y: `mask_around_peg`
PEG_TOP_Z = -0.148  # m, the peg tops in the arm's frame (shared/reference/peg-transfer-geometry.md)
STOP_Z = -0.120  # m, `height_ready` of all three motion scripts: where the carry stops and the look is taken
# m, `height_drop` by script: where the tip stops before the jaw opens
DROP_Z = {"unilateral": -0.130, "bilateral": -0.135, "handover": -0.138}


def paper_heights(motion: MotionSettings, variant: str) -> MotionSettings:
    """`motion` with the carry's stop and the lowering at the paper's heights above the peg tops."""
    transfer = replace(
        motion.transfer,
        transfer_height_above_peg_top=STOP_Z - PEG_TOP_Z,
        drop_height_above_peg_top=DROP_Z[variant] - PEG_TOP_Z,
    )
    return replace(motion, transfer=transfer)


@cache
def _camera() -> DepthCamera:
    return DepthCamera(workcell())


def visible_points(world: World, peg: int) -> int:
    """How many pixels of the work cell's camera see a block in `find_block_servo`'s box over `peg` (its
    colour mask keeps the red blocks, not the grey tool, which hides them where it is in front): only the
    pixels whose rays can cross the box are cast."""
    cell, camera = world.cell, _camera()
    model = cell.camera
    x, y = cell.pegs.positions[peg]
    heights = cell.board.surface_z - np.array(BAND)  # board z runs down
    corners = np.array(
        [[x + a, y + b, z] for a in (-HALF_BOX, HALF_BOX) for b in (-HALF_BOX, HALF_BOX) for z in heights]
    )
    rotation, origin = model.board_from_camera[:3, :3], model.board_from_camera[:3, 3]
    in_camera = (corners - origin) @ rotation
    u = model.fx * in_camera[:, 0] / in_camera[:, 2] + model.cx
    v = model.fy * in_camera[:, 1] / in_camera[:, 2] + model.cy
    columns = np.arange(max(int(np.floor(u.min())), 0), min(int(np.ceil(u.max())) + 1, model.width))
    rows = np.arange(max(int(np.floor(v.min())), 0), min(int(np.ceil(v.max())) + 1, model.height))
    directions = camera.directions_of(columns, rows)[0] @ rotation.T
    rays = np.hstack([np.broadcast_to(origin, directions.shape), directions]).astype(np.float32)
    vertices, triangles = camera.scene_mesh(world)
    scene = o3d.t.geometry.RaycastingScene()
    scene.add_triangles(
        o3d.core.Tensor.from_numpy(vertices.astype(np.float32)),
        o3d.core.Tensor.from_numpy(triangles.astype(np.uint32)),
    )
    hits = scene.cast_rays(o3d.core.Tensor.from_numpy(rays))
    depth = hits["t_hit"].numpy()
    first = hits["primitive_ids"].numpy().astype(np.int64) - camera.board_triangles
    seen = np.isfinite(depth) & (first >= 0) & (first < len(world.blocks) * camera.block_triangles)
    points = origin + directions[seen] * depth[seen, None]
    above = cell.board.surface_z - points[:, 2]
    inside = (
        (np.abs(points[:, 0] - x) < HALF_BOX)
        & (np.abs(points[:, 1] - y) < HALF_BOX)
        & (above > BAND[0])
        & (above < BAND[1])
    )
    return int(inside.sum())


def correction(
    world: World, arm: str, seen_bottom: NDArray[np.float64], peg: int, points: int
) -> NDArray[np.float64]:
    """The move (arm frame, m) `servoing_block` adds to the place position: the seen block's bottom on its
    axis (`seen_bottom`, board frame) onto the peg's axis, along the board as the robot believes its
    arm stands (the work cell's figures), its arm-frame z dropped; none when fewer than `MIN_POINTS`
    were seen."""
    if points < MIN_POINTS:
        return np.zeros(3)
    cell = world.cell
    delta = np.zeros(3)
    delta[:2] = np.asarray(cell.pegs.positions[peg]) - seen_bottom[:2]
    move = cell.board_to_arm(arm)[:3, :3] @ delta
    move[2] = 0.0
    return move
