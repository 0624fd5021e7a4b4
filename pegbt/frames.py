"""Rigid frames as 4×4 matrices: building, inverting and applying them, and distances between segments.

One home for what the work cell, the simulator, perception, motion and the behaviours all do with
poses, so a pose means the same thing (rotation in the top-left 3×3, position in the last column)
everywhere. Plain numpy on small arrays; perception moves whole point clouds with Open3D instead.
"""

from __future__ import annotations

import math

import numpy as np
from numpy.typing import ArrayLike, NDArray

Matrix = NDArray[np.float64]
_EPS = 1e-12


def rigid_transform(rotation: ArrayLike | None, position: ArrayLike) -> Matrix:
    """A 4×4 transform from a 3×3 rotation (identity if None) and a position."""
    T = np.eye(4)
    if rotation is not None:
        T[:3, :3] = rotation
    T[:3, 3] = position
    return T


def yaw_rotation(yaw: float) -> Matrix:
    """Rotation by `yaw` about z."""
    c, s = math.cos(yaw), math.sin(yaw)
    return np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])


def yaw_pose(position: ArrayLike, yaw: float) -> Matrix:
    """A 4×4 pose at `position`, turned by `yaw` about z."""
    return rigid_transform(yaw_rotation(yaw), position)


def yaw_of(T: ArrayLike) -> float:
    """Angle of a frame's x axis about z (its heading when roughly upright)."""
    T = np.asarray(T)
    return float(np.arctan2(T[1, 0], T[0, 0]))


def pose_from_axes(x: ArrayLike, z: ArrayLike, position: ArrayLike) -> Matrix:
    """The frame at `position` whose x and z axes are the given (orthogonal unit) vectors; y = z × x."""
    x, z = np.asarray(x, dtype=float), np.asarray(z, dtype=float)
    return rigid_transform(np.column_stack([x, np.cross(z, x), z]), position)


def invert_rigid(T: ArrayLike) -> Matrix:
    """Inverse of a rigid 4×4 transform (exact, and cheaper than a general inverse)."""
    T = np.asarray(T, dtype=float)
    return rigid_transform(T[:3, :3].T, -T[:3, :3].T @ T[:3, 3])


def apply_rigid(T: ArrayLike, points: ArrayLike) -> Matrix:
    """Points (..., 3) moved by the 4×4 transform `T`."""
    T = np.asarray(T, dtype=float)
    return np.asarray(points, dtype=float) @ T[:3, :3].T + T[:3, 3]


def segment_distances(p0: Matrix, p1: Matrix, q0: Matrix, q1: Matrix) -> Matrix:
    """Shortest distances between segments p0–p1 and q0–q1, broadcast over leading dimensions (…, 3).

    The clamped closest-point construction for two segments (as in Ericson, *Real-Time Collision
    Detection*, §5.1.9), written with array operations so one call covers every pair; a segment of
    zero length is a point.
    """
    d1, d2, r = p1 - p0, q1 - q0, p0 - q0
    a = np.einsum("...i,...i->...", d1, d1)
    e = np.einsum("...i,...i->...", d2, d2)
    b = np.einsum("...i,...i->...", d1, d2)
    c = np.einsum("...i,...i->...", d1, r)
    f = np.einsum("...i,...i->...", d2, r)
    safe_a, safe_e = np.maximum(a, _EPS), np.maximum(e, _EPS)
    denominator = a * e - b * b
    nearest_to_point = (-c / safe_a).clip(0.0, 1.0)  # when q is a point, or p and q are parallel
    s = np.where(
        denominator > _EPS,
        ((b * f - c * e) / np.maximum(denominator, _EPS)).clip(0.0, 1.0),
        nearest_to_point,
    )
    t = (b * s + f) / safe_e
    s = np.where(t < 0.0, nearest_to_point, np.where(t > 1.0, ((b - c) / safe_a).clip(0.0, 1.0), s))
    t = t.clip(0.0, 1.0)
    s = np.where(a > _EPS, s, 0.0)
    t = np.where(e > _EPS, t, 0.0)
    gap = (p0 + s[..., None] * d1) - (q0 + t[..., None] * d2)
    return np.linalg.norm(gap, axis=-1)
