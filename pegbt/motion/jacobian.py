"""Geometric Jacobian of the PSM tool tip, from the link frames of the forward kinematics.

Rows are (linear velocity; angular velocity) of the tip in the arm's base frame; columns are the six
joints. In the modified DH convention joint i moves along/about the z axis of link frame i.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike, NDArray

from pegbt.motion.kinematics import link_frames

PRISMATIC_JOINT = 2  # q3, the insertion


def jacobian(q: ArrayLike) -> NDArray[np.float64]:
    """Geometric Jacobian (..., 6, 6) of the tip at joints `q` (..., 6)."""
    frames = link_frames(q)
    tip = frames[-1][..., :3, 3]
    columns = []
    for joint in range(6):
        axis = frames[joint][..., :3, 2]
        if joint == PRISMATIC_JOINT:
            columns.append(np.concatenate([axis, np.zeros_like(axis)], axis=-1))
        else:
            lever = tip - frames[joint][..., :3, 3]
            columns.append(np.concatenate([np.cross(axis, lever), axis], axis=-1))
    return np.stack(columns, axis=-1)
