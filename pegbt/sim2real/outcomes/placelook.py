"""The phase simulator's side of the reference paper's look at the held block before it lowers it
(`place_servoing`, BerkeleyAutomation/FLSpegtransferHO): how many of the box's points the work cell's camera
sees, cast on the world's own meshes. The paper's heights, box and correction are the executive's too
(`pegbt.motion.placing`, `pegbt.perception.servo`, where its sources are cited).
"""

from __future__ import annotations

from functools import cache

import numpy as np
import open3d as o3d

from pegbt.perception.servo import BAND, HALF_BOX, in_servo_box
from pegbt.sim.camera import DepthCamera
from pegbt.sim.world import World
from pegbt.workcell import workcell


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
    return int(in_servo_box(points, np.array([x, y]), cell.board.surface_z).sum())
