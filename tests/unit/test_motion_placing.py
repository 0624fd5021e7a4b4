"""The paper's placing heights (`pegbt.motion.placing`): z values in the arm's own frame
(BerkeleyAutomation/FLSpegtransferHO, `motion/dvrkPegTransferMotionDualArm.py` lines 50-51 and 155), reached
along the pegs' axis by pegbt's own wrist, or straight down the base's z as the paper's `servoing_block`."""

from __future__ import annotations

import numpy as np
import pytest

from pegbt.errors import PegbtError
from pegbt.motion.placing import MIN_AXIS_RISE, along_to_z, paper_heights, straight_down
from pegbt.motion.waypoints import placement_waypoints, tool_down_rotation, transfer_waypoints

UP = np.array([0.02, -0.01, 1.0]) / np.linalg.norm([0.02, -0.01, 1.0])  # a board leaning 1.3 degrees
PICK_TOP = np.array([0.05, 0.01, -0.141])  # m, arm frame: peg tops 4 mm apart in z
PLACE_TOP = np.array([-0.02, 0.03, -0.145])


def lateral(vector: np.ndarray) -> np.ndarray:
    return vector - (vector @ UP) * UP


def test_the_paper_s_heights_are_z_in_the_arm_s_frame_whatever_the_peg_tops_z() -> None:
    carry = transfer_waypoints(PICK_TOP, PLACE_TOP, place_offset=[0.003, 0.0, 0.0], up=UP)
    paper = paper_heights(carry, "bilateral", UP)
    assert paper.poses[1:, 2, 3] == pytest.approx([-0.120, -0.120, -0.135], abs=1e-12)
    assert np.array_equal(paper.poses[0], carry.poses[0])  # the grasp stays where the block is
    for before, after in zip(carry.poses[1:], paper.poses[1:]):  # along the pegs' axis: on the same peg
        assert lateral(after[:3, 3] - before[:3, 3]) == pytest.approx(np.zeros(3), abs=1e-12)
        assert np.array_equal(after[:3, :3], before[:3, :3])
    # the goal's channel starts at the lowered tip; where the block clears the peg stays where it was
    assert paper.place.point == pytest.approx(paper.poses[3, :3, 3], abs=1e-12)
    assert paper.place.height(carry.place.point + carry.place.clear * UP) == pytest.approx(paper.place.clear)


def test_a_placement_keeps_its_start_and_the_paper_has_no_heights_for_other_variants() -> None:
    start = np.eye(4)
    start[:3, 3] = [0.0, 0.02, -0.110]
    placement = paper_heights(placement_waypoints(start, PLACE_TOP, up=UP), "handover", UP)
    assert np.array_equal(placement.poses[0], start) and np.array_equal(placement.poses[1], start)
    assert placement.poses[2:, 2, 3] == pytest.approx([-0.120, -0.138], abs=1e-12)
    with pytest.raises(PegbtError, match="heights for unilateral, bilateral, handover only") as raised:
        paper_heights(placement_waypoints(start, PLACE_TOP, up=UP), "lone", UP)
    assert raised.value.field == "variant"


def test_straight_down_puts_the_tool_along_the_base_s_z_over_the_place_point() -> None:
    place = PLACE_TOP + lateral(np.array([0.003, 0.001, 0.0]))
    carry = paper_heights(transfer_waypoints(PICK_TOP, PLACE_TOP, up=UP, place_yaw=0.4), "unilateral", UP)
    paper = straight_down(carry, place, 0.0)
    for pose, z in zip(paper.poses[2:], (-0.120, -0.130)):
        assert pose[:3, 3] == pytest.approx([place[0], place[1], z], abs=1e-12)
        assert pose[:3, :3] == pytest.approx(np.eye(3), abs=1e-12)  # roll 0, the tool along the base's z
    assert not np.allclose(carry.poses[3, :3, :3], tool_down_rotation(0.0))  # the pegs' axis leans
    assert paper.place.point == pytest.approx(paper.poses[3, :3, 3], abs=1e-12)
    assert np.array_equal(paper.poses[:2], carry.poses[:2])


@pytest.mark.parametrize(
    "axis", [[1.0, 0.0, 0.0], [1.0, 0.0, 1e-12], [0.0, -2.0, 0.9 * MIN_AXIS_RISE * 2.0], [0.0, 0.0, 0.0]]
)
def test_an_axis_that_barely_rises_cannot_reach_a_z(axis: list[float]) -> None:
    with pytest.raises(PegbtError, match="cannot reach z = -0.12 m") as raised:
        along_to_z(PICK_TOP, -0.120, axis)
    assert raised.value.field == "axis"


def test_an_axis_that_rises_enough_reaches_the_z_along_itself() -> None:
    axis = np.array([0.0, -2.0, 1.1 * MIN_AXIS_RISE * 2.0])
    moved = along_to_z(PICK_TOP, -0.120, axis)
    assert moved[2] == pytest.approx(-0.120, abs=1e-12)
    assert np.cross(moved - PICK_TOP, axis) == pytest.approx(np.zeros(3), abs=1e-12)
