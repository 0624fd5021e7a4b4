"""Triangle meshes of the work cell (board, pegs, blocks, tool segments) for the depth camera to see.

Plain numpy arrays (vertices (n, 3) float, triangles (m, 3) int), outward-facing, built from the
work cell's dimensions; perception may sample the block mesh as its registration model.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

from pegbt.frames import Matrix
from pegbt.workcell import BlockModel, Workcell

Mesh = tuple[Matrix, NDArray[np.int64]]
HOLE_SEGMENTS = 48
CYLINDER_SEGMENTS = 16


def _ring_band(n: int, flip: bool, offset: int) -> list[list[int]]:
    """Triangles of the band between an outer and an inner ring of `n` vertices each, from index `offset`."""
    triangles = []
    for i in range(n):
        j = (i + 1) % n
        a, b, c, d = (
            offset + i,
            offset + j,
            offset + n + i,
            offset + n + j,
        )  # outer i, outer j, inner i, inner j
        triangles += [[a, b, d], [a, d, c]] if not flip else [[a, d, b], [a, c, d]]
    return triangles


def block_mesh(model: BlockModel) -> Mesh:
    """The block in its own frame: hexagonal outline, central hole, bottom face at z = 0, top at -height.

    Outline and hole are sampled at the same angles (the hole's segments plus the outline's corners),
    so faces and walls are quad strips between two rings.
    """
    corners = np.arctan2(model.outline[:, 1], model.outline[:, 0])
    angles = np.unique(np.concatenate([np.linspace(-np.pi, np.pi, HOLE_SEGMENTS, endpoint=False), corners]))
    directions = np.column_stack([np.cos(angles), np.sin(angles)])
    normals, offsets = model.outline_planes
    facing = directions @ normals.T
    reach = np.where(facing > 1e-9, offsets / np.maximum(facing, 1e-9), np.inf).min(axis=1)
    outer, inner = directions * reach[:, None], directions * model.hole_radius
    n = len(angles)
    rings = []  # outer top, inner top, outer bottom, inner bottom
    for ring, z in ((outer, -model.height), (inner, -model.height), (outer, 0.0), (inner, 0.0)):
        rings.append(np.column_stack([ring, np.full(n, z)]))
    vertices = np.concatenate(rings)
    top, bottom = 0, 2 * n
    # z points down, so "up" faces are seen from -z; windings keep normals pointing out of the solid
    triangles = _ring_band(n, flip=True, offset=top)
    triangles += _ring_band(n, flip=False, offset=bottom)
    for i in range(n):
        j = (i + 1) % n
        triangles += [[top + i, top + j, bottom + j], [top + i, bottom + j, bottom + i]]  # outer wall
        ti, tj, bi, bj = top + n + i, top + n + j, bottom + n + i, bottom + n + j
        triangles += [[ti, bj, tj], [ti, bi, bj]]  # hole wall
    return vertices, np.array(triangles)


def cylinder_mesh(start: Matrix, end: Matrix, radius: float, segments: int = CYLINDER_SEGMENTS) -> Mesh:
    """A capped cylinder around the segment start–end."""
    axis = np.asarray(end, dtype=float) - start
    unit = axis / np.linalg.norm(axis)
    helper = np.array([1.0, 0.0, 0.0]) if abs(unit[0]) < 0.9 else np.array([0.0, 1.0, 0.0])
    u = np.cross(unit, helper)
    u /= np.linalg.norm(u)
    v = np.cross(unit, u)
    angles = np.linspace(0.0, 2 * np.pi, segments, endpoint=False)
    circle = radius * (np.outer(np.cos(angles), u) + np.outer(np.sin(angles), v))
    vertices = np.concatenate([start + circle, end + circle, [start, end]])
    centre_start, centre_end = 2 * segments, 2 * segments + 1
    triangles = []
    for i in range(segments):
        j = (i + 1) % segments
        triangles += [[i, j, segments + j], [i, segments + j, segments + i]]
        triangles += [[centre_start, j, i], [centre_end, segments + i, segments + j]]
    return vertices, np.array(triangles)


def box_mesh(low: Matrix, high: Matrix) -> Mesh:
    """An axis-aligned box."""
    corners = np.array(
        [[x, y, z] for x in (low[0], high[0]) for y in (low[1], high[1]) for z in (low[2], high[2])]
    )
    faces = [[0, 1, 3, 2], [4, 6, 7, 5], [0, 4, 5, 1], [2, 3, 7, 6], [0, 2, 6, 4], [1, 5, 7, 3]]
    return corners, np.array([t for a, b, c, d in faces for t in ([a, b, c], [a, c, d])])


def merge(meshes: list[Mesh]) -> Mesh:
    """One mesh holding all of `meshes`."""
    vertices, triangles, count = [], [], 0
    for v, t in meshes:
        vertices.append(v)
        triangles.append(t + count)
        count += len(v)
    return np.concatenate(vertices), np.concatenate(triangles)


def transformed(mesh: Mesh, T: Matrix) -> Mesh:
    """`mesh` moved by the 4×4 transform `T`."""
    vertices, triangles = mesh
    return vertices @ T[:3, :3].T + T[:3, 3], triangles


def static_scene_mesh(cell: Workcell) -> Mesh:
    """The board (a slab under its surface) and the twelve pegs, in the board frame."""
    board, pegs = cell.board, cell.pegs
    slab = box_mesh(
        np.array([board.extent_x[0], board.extent_y[0], board.surface_z]),
        np.array([board.extent_x[1], board.extent_y[1], board.surface_z + board.thickness]),
    )
    feet = np.column_stack([pegs.positions, np.full(len(pegs.positions), board.surface_z)])
    return merge([slab] + [cylinder_mesh(foot, top, pegs.radius) for foot, top in zip(feet, pegs.tops)])
