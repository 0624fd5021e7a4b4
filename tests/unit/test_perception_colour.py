"""The paper's red mask (FLSpegtransferHO `vision/BlockDetection3D.py`: OpenCV HSV within (0−20, 60, 40) and
(0+20, 255, 255)) on the colours the simulated camera gives the scene."""

from __future__ import annotations

import numpy as np
import pytest

from pegbt.perception.colour import colours_of, red
from pegbt.sim.camera import BOARD_GREY, RED, TOOL_GREY, rgba_word
from pegbt.transport.camera import ColouredPoints


@pytest.mark.parametrize(
    ("rgb", "kept"),
    [
        ((200, 40, 30), True),  # hue 4°
        ((255, 0, 0), True),  # hue 0°
        ((200, 150, 0), False),  # hue 45°: beyond OpenCV's 20 half-degrees
        ((200, 30, 40), False),  # hue 357°: cv2.inRange's lower bound −20 does not wrap round to 340°
        ((200, 140, 130), True),  # pale red: saturation 0.35 ≥ 60/255
        ((200, 180, 175), False),  # saturation 0.125 < 60/255
        ((30, 6, 4), False),  # value 30/255 < 40/255
        ((185, 185, 180), False),  # the board
        ((60, 60, 64), False),  # the tool
    ],
)
def test_the_mask_keeps_what_opencv_s_in_range_keeps(rgb, kept):
    assert bool(red(np.array([rgba_word(*rgb)], dtype=np.uint32))[0]) == kept


def test_the_scene_s_colours_are_red_where_the_paper_s_mask_finds_blocks_and_pegs():
    assert red(np.array([RED, BOARD_GREY, TOOL_GREY, 0], dtype=np.uint32)).tolist() == [
        True,
        False,
        False,
        False,
    ]


def test_a_cloud_s_colours_are_read_from_whatever_carries_them():
    points = np.zeros((2, 3), dtype=np.float32)
    assert colours_of(points) is None
    assert list(colours_of(ColouredPoints(points, np.array([RED, 0], dtype=np.uint32)))) == [RED, 0]
