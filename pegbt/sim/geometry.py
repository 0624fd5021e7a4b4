"""Small rigid-body and distance helpers the world and camera share."""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

Matrix = NDArray[np.float64]
_EPS = 1e-12


def pose(position: Matrix, rotation: Matrix | None = None) -> Matrix:
    """A 4×4 transform from a position and a 3×3 rotation (identity if omitted)."""
    T = np.eye(4)
    if rotation is not None:
        T[:3, :3] = rotation
    T[:3, 3] = position
    return T


def yaw_rotation(yaw: float) -> Matrix:
    """Rotation by `yaw` about z."""
    c, s = np.cos(yaw), np.sin(yaw)
    return np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])


def yaw_of(T: Matrix) -> float:
    """Angle of a frame's x axis about z (its heading when roughly upright)."""
    return float(np.arctan2(T[1, 0], T[0, 0]))


def segment_distances(p0: Matrix, p1: Matrix, q0: Matrix, q1: Matrix) -> Matrix:
    """Shortest distances between segments p0–p1 and q0–q1, broadcast over leading dimensions (…, 3).

    The clamped closest-point construction for two segments (as in Ericson, *Real-Time Collision
    Detection*, §5.1.9), written with array operations so one call covers every pair.
    """
    d1, d2, r = p1 - p0, q1 - q0, p0 - q0
    a = np.einsum("...i,...i->...", d1, d1)
    e = np.einsum("...i,...i->...", d2, d2)
    b = np.einsum("...i,...i->...", d1, d2)
    c = np.einsum("...i,...i->...", d1, r)
    f = np.einsum("...i,...i->...", d2, r)
    safe_a, safe_e = np.maximum(a, _EPS), np.maximum(e, _EPS)
    denominator = a * e - b * b
    nearest_to_point = np.clip(-c / safe_a, 0.0, 1.0)  # when q is a point, or p and q are parallel
    s = np.where(denominator > _EPS, np.clip((b * f - c * e) / np.maximum(denominator, _EPS), 0.0, 1.0), nearest_to_point)
    t = (b * s + f) / safe_e
    s = np.where(t < 0.0, np.clip(-c / safe_a, 0.0, 1.0), np.where(t > 1.0, np.clip((b - c) / safe_a, 0.0, 1.0), s))
    t = np.clip(t, 0.0, 1.0)
    s = np.where(a > _EPS, s, 0.0)
    t = np.where(e > _EPS, t, 0.0)
    gap = (p0 + s[..., None] * d1) - (q0 + t[..., None] * d2)
    return np.linalg.norm(gap, axis=-1)


def boxes_overlap(low_a: Matrix, high_a: Matrix, low_b: Matrix, high_b: Matrix) -> Matrix:
    """Whether axis-aligned boxes overlap, broadcast over leading dimensions (…, 3) -> (…)."""
    return np.all((low_a <= high_b) & (low_b <= high_a), axis=-1)
