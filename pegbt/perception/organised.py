"""Where to look in an organised cloud: the pixels near anything raised off the registered board.

A Zivid 2 sends its whole 1944 × 1200 image, 2.3 M pixels, of which the blocks are a few percent. An
organised cloud is an image, so finding them needs no point search: every `COARSE`-th pixel of every
`COARSE`-th row (a block's top is still a dozen of them) is taken to the board frame in numpy, element by
element (the board's plane is known from its registration, so "raised" is a height band), and the pixels
within one coarse pixel of a raised one are copied out of the image at full resolution. Only they go on to
Open3D (voxel grid, DBSCAN, ICP: `pegbt.perception.segment`, `pegbt.perception.blocks`), which so sees every
point the camera has of each block, and nothing of the bare board.
"""

from __future__ import annotations

from typing import Protocol, runtime_checkable

import numpy as np
from numpy.typing import NDArray
from scipy import ndimage

from pegbt.perception.cloud import Points

COARSE = 8  # pixels between the looks of the first pass: 2.6 mm at the board for a Zivid 2 over it


@runtime_checkable
class OrganisedCloud(Protocol):
    """A capture that keeps its image: `grid` (H, W, 3) float32, camera frame, metres, NaN where a pixel has
    no depth (a view of the message it came in, copied only where taken)."""

    grid: NDArray[np.float32]


def raised_points(
    grid: NDArray[np.float32], board_from_camera: NDArray[np.float64], low: float, high: float
) -> Points:
    """The valid points (M, 3, camera frame) of `grid` near a pixel whose board-frame height z lies in
    (`high`, `low`) (board z points down: `low` is nearer the board), at full resolution."""
    coarse = np.asarray(grid[::COARSE, ::COARSE], dtype=np.float64)
    R, t = board_from_camera[2, :3], board_from_camera[2, 3]
    with np.errstate(invalid="ignore"):  # NaN pixels compare False: not raised
        z = R[0] * coarse[..., 0] + R[1] * coarse[..., 1] + R[2] * coarse[..., 2] + t
        near = ndimage.binary_dilation((z < low) & (z > high), np.ones((3, 3), dtype=bool))
    rows, columns = np.flatnonzero(near.any(axis=1)), np.flatnonzero(near.any(axis=0))
    if len(rows) == 0:
        return np.zeros((0, 3))
    r0, r1, c0, c1 = rows[0], rows[-1] + 1, columns[0], columns[-1] + 1
    window = grid[r0 * COARSE : r1 * COARSE, c0 * COARSE : c1 * COARSE]
    mask = np.repeat(np.repeat(near[r0:r1, c0:c1], COARSE, axis=0), COARSE, axis=1)
    points = window[mask[: window.shape[0], : window.shape[1]]]
    return np.asarray(points[np.isfinite(points).all(axis=1)], dtype=np.float64)
