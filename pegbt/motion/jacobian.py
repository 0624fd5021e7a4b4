"""Geometric Jacobian of the PSM tool tip, from the link frames of the forward kinematics.

Rows are (linear velocity; angular velocity) of the tip in the arm's base frame; columns are the six
joints. In the modified DH convention joint i moves along/about the z axis of link frame i.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike, NDArray

from pegbt.motion.kinematics import link_frames

PRISMATIC_JOINT = 2  # q3, the insertion


def cross(a: NDArray[np.float64], b: NDArray[np.float64]) -> NDArray[np.float64]:
    """Cross product over the last axis; `np.cross` costs tens of µs of axis juggling per call, which
    matters in the planner's inner loop."""
    return np.stack(
        [
            a[..., 1] * b[..., 2] - a[..., 2] * b[..., 1],
            a[..., 2] * b[..., 0] - a[..., 0] * b[..., 2],
            a[..., 0] * b[..., 1] - a[..., 1] * b[..., 0],
        ],
        axis=-1,
    )


def jacobian_from_frames(frames: list[NDArray[np.float64]]) -> NDArray[np.float64]:
    """Geometric Jacobian (..., 6, 6) from the link frames of `link_frames` (reuse them with the pose)."""
    tip = frames[-1][..., :3, 3]
    J = np.zeros(tip.shape[:-1] + (6, 6))
    for joint in range(6):
        axis = frames[joint][..., :3, 2]
        if joint == PRISMATIC_JOINT:
            J[..., :3, joint] = axis
        else:
            J[..., :3, joint] = cross(axis, tip - frames[joint][..., :3, 3])
            J[..., 3:, joint] = axis
    return J


def jacobian(q: ArrayLike) -> NDArray[np.float64]:
    """Geometric Jacobian (..., 6, 6) of the tip at joints `q` (..., 6)."""
    return jacobian_from_frames(link_frames(q))
