"""Reading simulated point clouds in tests: board-frame points and the points on one block's surface."""

import numpy as np


def in_board(cell, cloud):
    """Camera-frame points (N, 3) in the board frame."""
    T = cell.camera.board_from_camera
    return cloud.astype(float) @ T[:3, :3].T + T[:3, 3]


def block_points(cell, board_points, pose):
    """Points on the surface of a block at `pose` (4×4, board frame), in the block frame."""
    local = (board_points - pose[:3, 3]) @ pose[:3, :3]
    normals, offsets = cell.block.outline_planes
    inside = (local[:, :2] @ normals.T - offsets).max(axis=1) < 0.0005
    radial = np.linalg.norm(local[:, :2], axis=1)
    height = cell.block.height
    on = (
        inside
        & (radial > cell.block.hole_radius - 0.0005)
        & (local[:, 2] > -height - 0.0005)
        & (local[:, 2] < -0.0005)
    )
    return local[on]
