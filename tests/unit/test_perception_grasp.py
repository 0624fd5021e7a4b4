"""Grasp selection: the yaw window, the reachability predicate, the farthest-from-peg rule, the receiver's rule."""

import math

import numpy as np
import pytest
from grasp_helpers import CELL, estimate_at, everywhere, off_peg

from pegbt.errors import PegbtError
from pegbt.motion.handover import handover_meeting_point
from pegbt.motion.settings import motion_settings
from pegbt.perception.blocks import BlockEstimate, block_on_peg, locate_blocks
from pegbt.perception.board import PegboardRegistration
from pegbt.perception.grasp import PEG_DISTANCE_TIE, YAW_WINDOW, GraspSelector, grasp_options, select_grasp
from pegbt.sim.camera import DepthCamera
from pegbt.sim.scripted import Driver, Keyframe, carry_height, lifted


def distance_from_peg(grasp, peg):
    return np.linalg.norm(grasp.board_position[:2] - CELL.pegs.positions[peg])


def test_the_six_options_are_the_block_candidates_expressed_in_the_arm_frame():
    block = off_peg(3, 40.0)
    for arm in ("PSM1", "PSM2"):
        options = grasp_options(block.pose, arm)
        assert [option.candidate for option in options] == list(range(6))
        local = np.column_stack([CELL.block.grasp_candidates.positions, np.ones(6)])
        in_board = (block.pose @ local.T).T[:, :3]
        for option, expected in zip(options, in_board):
            assert np.allclose(option.board_position, expected)
            assert np.allclose(option.position, (CELL.board_to_arm(arm) @ np.append(expected, 1.0))[:3])
            rotation = option.pose[:3, :3]
            assert np.allclose(rotation.T @ rotation, np.eye(3)) and np.linalg.det(rotation) == pytest.approx(
                1.0
            )
            assert rotation[2, 2] > 0.99  # the tool points down: its z axis is the arm's up
            assert -math.pi / 2 < option.yaw <= math.pi / 2
            assert option.yaw == pytest.approx(math.atan2(rotation[1, 0], rotation[0, 0]))


@pytest.mark.parametrize("direction_deg", [0.0, 75.0, 150.0, 225.0, 300.0])
def test_the_farthest_feasible_candidate_from_the_peg_is_chosen(direction_deg):
    block = off_peg(2, direction_deg)
    grasp = select_grasp(block, "PSM1", everywhere)
    feasible = [option for option in grasp_options(block.pose, "PSM1") if abs(option.yaw) <= YAW_WINDOW]
    farthest = max(distance_from_peg(option, 2) for option in feasible)
    assert grasp is not None and abs(grasp.yaw) <= YAW_WINDOW
    assert distance_from_peg(grasp, 2) >= farthest - PEG_DISTANCE_TIE
    # the jaw works on the side away from the peg: the block's centre lies between the grasp and the peg
    towards_grasp = grasp.board_position[:2] - block.position[:2]
    towards_peg = CELL.pegs.positions[2] - block.position[:2]
    assert towards_grasp @ towards_peg < 0


def test_on_a_centred_block_the_candidate_nearest_the_arm_wins_the_tie():
    block = estimate_at(CELL.pegs.positions[4], 0.2, 4)
    for arm in ("PSM1", "PSM2"):
        grasp = select_grasp(block, arm, everywhere)
        centre = CELL.remote_centre(arm)[:2]
        feasible = [option for option in grasp_options(block.pose, arm) if abs(option.yaw) <= YAW_WINDOW]
        nearest = min(feasible, key=lambda option: np.linalg.norm(option.board_position[:2] - centre))
        assert grasp.candidate == nearest.candidate


def test_candidates_outside_the_yaw_window_are_never_chosen():
    # find a block yaw whose farthest candidate lies outside the window, so the window must matter
    for yaw in np.radians(np.arange(-60.0, 60.0, 5.0)):
        block = off_peg(1, 90.0, yaw=yaw)
        options = grasp_options(block.pose, "PSM1")
        farthest = max(options, key=lambda option: distance_from_peg(option, 1))
        if abs(farthest.yaw) > YAW_WINDOW:
            break
    else:
        pytest.fail("no yaw puts the farthest candidate outside the window")
    grasp = select_grasp(block, "PSM1", everywhere)
    assert grasp is not None and abs(grasp.yaw) <= YAW_WINDOW
    assert grasp.candidate != farthest.candidate
    assert GraspSelector("PSM1", everywhere, yaw_window=math.radians(1.0)).pick(block) is None


def test_the_reachability_predicate_is_respected_and_sees_arm_frame_poses_in_the_window():
    block = off_peg(0, 120.0)
    best = select_grasp(block, "PSM2", everywhere)
    seen = []

    def all_but_best(poses):
        seen.append(poses.copy())
        return np.array([not np.allclose(pose, best.pose) for pose in poses])

    second = select_grasp(block, "PSM2", all_but_best)
    assert second is not None and second.candidate != best.candidate
    assert len(seen) == 1 and seen[0].shape[1:] == (4, 4)
    in_window = [option.pose for option in grasp_options(block.pose, "PSM2") if abs(option.yaw) <= YAW_WINDOW]
    assert np.allclose(seen[0], in_window)
    assert select_grasp(block, "PSM2", lambda poses: np.zeros(len(poses), dtype=bool)) is None


def test_a_handover_receiver_takes_the_candidate_nearest_to_itself():
    held = estimate_at(handover_meeting_point(CELL)[:2], -0.4, None).pose
    for receiver in ("PSM1", "PSM2"):
        grasp = GraspSelector(receiver, everywhere).receive(held)
        centre = CELL.remote_centre(receiver)[:2]
        feasible = [option for option in grasp_options(held, receiver) if abs(option.yaw) <= YAW_WINDOW]
        distances = [np.linalg.norm(option.board_position[:2] - centre) for option in feasible]
        assert np.linalg.norm(grasp.board_position[:2] - centre) == pytest.approx(min(distances))


def test_a_perceived_grasp_grips_the_block_in_the_world():
    from pegbt.sim.world import World

    world = World(seed=4)
    board = PegboardRegistration().fit(DepthCamera(seed=4).capture(world))
    estimates = locate_blocks(DepthCamera(seed=5).capture(world), board)
    for arm, block in (("PSM1", 1), ("PSM2", 0)):
        grasp = select_grasp(block_on_peg(estimates, world.blocks[block].peg), arm, everywhere)
        tip = CELL.arm_to_board(arm) @ grasp.pose
        yaw = math.atan2(tip[1, 0], tip[0, 0])
        motion = motion_settings().transfer
        above = tip[:3, 3] - [0.0, 0.0, CELL.block.grasp_depth + motion.approach_above_block]
        at_grasp = Keyframe(tip[:3, 3], yaw, motion.jaw_open)
        driver = Driver(world)
        over = Keyframe(np.array([above[0], above[1], carry_height(world)]), yaw, motion.jaw_open)
        path = [
            over,
            Keyframe(above, yaw, motion.jaw_open),
            at_grasp,
            Keyframe(tip[:3, 3], yaw, motion.jaw_closed),
        ]
        events = driver.play({arm: [*path, lifted(world, path[-1])]})
        assert [event.kind for event in events][:2] == ["grasp", "lift"], events
        assert events[0].block == block and events[0].arm == arm


def test_a_failed_estimate_or_a_malformed_predicate_raises_a_pegbt_error():
    failed = BlockEstimate(np.zeros(3), 0.0, 2, 0.2, 0.001, 900, ok=False, reason="block model fits only 20%")
    with pytest.raises(PegbtError, match="not trustworthy") as raised:
        select_grasp(failed, "PSM1", everywhere)
    assert raised.value.field == "block"
    with pytest.raises(PegbtError) as raised:
        select_grasp(off_peg(2, 0.0), "PSM1", lambda poses: np.ones(len(poses) + 1, dtype=bool))
    assert raised.value.field == "reachable"
    with pytest.raises(PegbtError, match="unknown arm"):
        select_grasp(off_peg(2, 0.0), "PSM3", everywhere)
