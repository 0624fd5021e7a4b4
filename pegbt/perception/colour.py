"""The reference paper's colour mask: the red points of a cloud whose points have a colour.

FLSpegtransferHO `vision/BlockDetection3D.py` keeps, before every look (`find_pegs`, `find_block`,
`find_block_servo`, `find_block_servo_handover`), the pixels whose HSV colour `cv2.inRange` finds within
`lower_red` = (0 − 20, 60, 40) and `upper_red` = (0 + 20, 255, 255): OpenCV's hue of an 8-bit image runs
0–179 in units of 2°, so a hue of at most 40°, a saturation of at least 60/255 and a value of at least 40/255.
The blocks and the pegs are red; the board and the grey instruments are not, so the mask drops the tools
wherever they stand.
"""

from __future__ import annotations

from typing import Protocol, runtime_checkable

import numpy as np
from numpy.typing import NDArray

HUE_AT_MOST = 40.0 / 360.0  # `upper_red`'s 20 in OpenCV's half-degrees, as matplotlib's fraction of a turn
SATURATION_AT_LEAST = 60 / 255
VALUE_AT_LEAST = 40 / 255


@runtime_checkable
class ColouredCloud(Protocol):
    """A capture whose points have a colour: `rgba`, one word a point (`0xAARRGGBB`, zivid-ros's `rgba`)
    laid out as the points are ((N,) beside an (N, 3) cloud, (H, W) beside an organised cloud's grid), or
    None when the camera sent none."""

    rgba: NDArray[np.uint32] | None


def colours_of(cloud: object) -> NDArray[np.uint32] | None:
    """`cloud`'s rgba words as one row a point (the grid's pixels row by row), or None if it has none."""
    if isinstance(cloud, ColouredCloud) and cloud.rgba is not None:
        return np.asarray(cloud.rgba, dtype=np.uint32).reshape(-1)
    return None


def red(rgba: NDArray[np.uint32]) -> NDArray[np.bool_]:
    """Which rgba words the paper's mask keeps (`lower_red`, `upper_red`)."""
    from matplotlib.colors import rgb_to_hsv

    words = np.asarray(rgba, dtype=np.uint32)
    rgb = np.stack([(words >> shift) & 0xFF for shift in (16, 8, 0)], axis=-1) / 255.0
    hsv = rgb_to_hsv(rgb)
    return (
        (hsv[..., 0] <= HUE_AT_MOST) & (hsv[..., 1] >= SATURATION_AT_LEAST) & (hsv[..., 2] >= VALUE_AT_LEAST)
    )
