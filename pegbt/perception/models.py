"""Registration models: the surfaces of the board, pegs and block the camera can see, as point clouds.

Sampled from the simulator's meshes (one geometry for both), keeping only faces that look up or
sideways: a face turned towards the board (the slab's underside, a block's bottom) is never seen, and
leaving it in lets ICP lock the board's top onto its underside, a slab thickness away.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np

from pegbt.sim.meshes import Mesh, block_mesh, static_scene_mesh
from pegbt.workcell import Workcell

if TYPE_CHECKING:
    import open3d as o3d

_FACING_DOWN = 0.5  # z component (board z points down) above which a face's normal faces the board


def visible_surface_samples(mesh: Mesh, count: int, seed: int = 0) -> o3d.geometry.PointCloud:
    """`count` points spread uniformly over the faces of `mesh` that do not face down, with normals."""
    import open3d as o3d

    vertices, triangles = mesh
    surface = o3d.geometry.TriangleMesh(
        o3d.utility.Vector3dVector(vertices), o3d.utility.Vector3iVector(triangles.astype(np.int32))
    )
    surface.compute_triangle_normals()
    surface.remove_triangles_by_mask((np.asarray(surface.triangle_normals)[:, 2] > _FACING_DOWN).tolist())
    surface.remove_unreferenced_vertices()
    surface.compute_triangle_normals()
    o3d.utility.random.seed(seed)
    return surface.sample_points_uniformly(count, use_triangle_normal=True)


def board_model(cell: Workcell, count: int) -> o3d.geometry.PointCloud:
    """The board's top and sides and the twelve pegs, in the board frame."""
    return visible_surface_samples(static_scene_mesh(cell), count)


def block_model(cell: Workcell, count: int) -> o3d.geometry.PointCloud:
    """The block's top, outer walls and hole wall, in the block frame."""
    return visible_surface_samples(block_mesh(cell.block), count)
