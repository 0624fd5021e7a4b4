"""The room a peg has in the paper's block's hole: 1.8–2.0 mm towards a wall, 2.9 mm towards a corner."""

import math

import numpy as np
import pytest

from pegbt.sim.hole import HoleRoom
from pegbt.workcell import workcell

PEG = 0.0016


def _room(lobe: float = 0.0045, flat: float = 0.0036) -> HoleRoom:
    return HoleRoom(lobe - PEG, flat - PEG, workcell().block.edge_normals)


def _towards(degrees: float, distance: float) -> np.ndarray:
    return distance * np.array([math.cos(math.radians(degrees)), math.sin(math.radians(degrees))])


@pytest.mark.parametrize(
    ("degrees", "reach"), [(90, 0.0020), (210, 0.0020), (330, 0.0020), (30, 0.0029), (270, 0.0029)]
)
def test_a_peg_stands_clear_as_far_as_the_wall_or_the_lobe_lets_it(degrees, reach):
    room = _room()
    assert room.within(_towards(degrees, reach - 1e-6))[0]
    assert not room.within(_towards(degrees, reach + 1e-6))[0]
    assert room.outside(_towards(degrees, reach + 0.0003))[0] == pytest.approx(0.0003, abs=1e-9)


def test_the_nearest_point_of_the_room_lies_on_its_border_and_nothing_inside_moves():
    room, rng = _room(), np.random.default_rng(3)
    points = rng.uniform(-0.005, 0.005, size=(200, 2))
    nearest = room.nearest(points)
    assert room.within(nearest, 1e-12).all()
    inside = room.within(points)
    assert np.allclose(nearest[inside], points[inside])
    for point, near in zip(points[~inside], nearest[~inside]):  # no border point is nearer than it
        angles = np.linspace(0, 2 * math.pi, 720, endpoint=False)
        border = room.nearest(point[None] + 0.01 * np.column_stack([np.cos(angles), np.sin(angles)]))
        assert np.linalg.norm(point - near) <= np.linalg.norm(border - point, axis=1).min() + 1e-9


def test_a_round_hole_is_a_disc_of_the_clearance():
    room = _room(lobe=0.0036)
    for degrees in range(0, 360, 15):
        assert room.outside(_towards(degrees, 0.0025))[0] == pytest.approx(0.0005, abs=1e-9)


def test_a_block_slides_on_its_peg_until_the_hole_meets_it():
    room = _room(lobe=0.0036)
    normal = np.array([0.0, 1.0])
    assert room.slide(np.zeros(2), normal, 0.003, 0.0) == pytest.approx(0.002, abs=1e-9)
    assert room.slide(np.zeros(2), normal, -0.001, 0.0) == -0.001  # not as far as the hole
    assert room.slide(_towards(90, 0.0025), normal, 0.001, 0.0) == 0.0  # already pressed against it
