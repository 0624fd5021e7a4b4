"""Block location: every block to half a millimetre and two degrees, dropped blocks, empty pegs, noise bursts."""

import math

import numpy as np
import pytest

from pegbt.behaviours.poses import transfer_for
from pegbt.behaviours.resources.skills import Skills
from pegbt.frames import yaw_of, yaw_pose
from pegbt.motion.settings import motion_settings
from pegbt.perception.blocks import block_on_peg, locate_blocks, stack_level, wrap_symmetric
from pegbt.perception.board import PegboardRegistration
from pegbt.perception.settings import perception_settings
from pegbt.sim.camera import DepthCamera
from pegbt.sim.faults import CameraFaults, NoiseBurst
from pegbt.sim.scripted import (
    Driver,
    Keyframe,
    grasp_candidate_facing,
    grasp_keyframes,
    lifted,
    parked,
    transfer_keyframes,
)
from pegbt.sim.world import World

POSITION_TOLERANCE = 0.0005
YAW_TOLERANCE = math.radians(2.0)


@pytest.fixture(scope="module")
def board():
    """The board registered once, as a trial does, from a capture of the starting scene."""
    board = PegboardRegistration().fit(DepthCamera(seed=99).capture(World(seed=0)))
    assert board.ok, board.reason
    return board


def errors(estimate, block):
    """Position error (m) and yaw error modulo 120° (rad) of an estimate against the world's block."""
    return (
        float(np.linalg.norm(estimate.position - block.pose[:3, 3])),
        abs(wrap_symmetric(estimate.yaw - yaw_of(block.pose))),
    )


@pytest.mark.parametrize("seed", [0, 1, 2, 3])
def test_all_six_blocks_are_located_on_their_pegs(board, seed):
    world = World(seed=seed)
    estimates = locate_blocks(DepthCamera(seed=seed).capture(world), board)
    assert len(estimates) == 6
    for block in world.blocks:
        estimate = block_on_peg(estimates, block.peg)
        assert estimate is not None and estimate.ok, (block.index, estimate)
        position_error, yaw_error = errors(estimate, block)
        assert position_error < POSITION_TOLERANCE, block.index
        assert yaw_error < YAW_TOLERANCE, block.index
        assert -math.pi / 3 <= estimate.yaw < math.pi / 3
        assert estimate.fitness > 0.9


def test_a_block_dropped_on_the_board_is_found_off_the_pegs(board):
    world = World(seed=5)
    driver = Driver(world)
    grasp = grasp_keyframes(world, 2, grasp_candidate_facing(world, 2, "PSM1"))
    up = lifted(world, grasp[-1])
    away = Keyframe(np.array([0.110, 0.065, up.position[2]]), up.yaw, up.jaw)
    opened = Keyframe(away.position, away.yaw, motion_settings().transfer.jaw_open)
    events = driver.play({"PSM1": [*grasp, up, away, opened]})
    driver.play({"PSM1": [parked(world, "PSM1")]})
    assert [event.kind for event in events][-1] == "drop" and world.blocks[2].state == "on_board"

    estimates = locate_blocks(DepthCamera(seed=5).capture(world), board)

    dropped = [estimate for estimate in estimates if estimate.peg is None]
    assert len(dropped) == 1 and dropped[0].ok, dropped
    position_error, yaw_error = errors(dropped[0], world.blocks[2])
    assert position_error < POSITION_TOLERANCE and yaw_error < YAW_TOLERANCE
    assert block_on_peg(estimates, 2) is None
    assert sorted(estimate.peg for estimate in estimates if estimate.peg is not None) == [0, 1, 3, 4, 5]


def test_a_block_moved_away_leaves_its_peg_reported_empty(board):
    world = World(seed=6)
    driver = Driver(world)
    driver.play({"PSM1": transfer_keyframes(world, 1, 7, grasp_candidate_facing(world, 1, "PSM1"))})
    driver.play({"PSM1": [parked(world, "PSM1")]})

    estimates = locate_blocks(DepthCamera(seed=6).capture(world), board)

    assert block_on_peg(estimates, 1) is None
    moved = block_on_peg(estimates, 7)
    assert moved is not None and moved.ok
    assert errors(moved, world.blocks[1])[0] < POSITION_TOLERANCE
    assert len(estimates) == 6


@pytest.mark.parametrize(
    "burst",
    [
        NoiseBurst(0.0, 1.0),
        NoiseBurst(0.0, 1.0, sigma=0.001),
        NoiseBurst(0.0, 1.0, sigma=0.0006, outliers=0.02),
    ],
    ids=["default", "1mm", "0.6mm"],
)
def test_a_noise_burst_gives_a_correct_pose_or_an_explicit_failure(board, burst):
    world = World(seed=7)
    estimates = locate_blocks(DepthCamera(seed=7, faults=CameraFaults(bursts=(burst,))).capture(world), board)
    assert estimates, "a burst must not make the blocks vanish silently"
    for estimate in estimates:
        if not estimate.ok:
            assert estimate.reason
            continue
        nearest = min(
            world.blocks, key=lambda block: np.linalg.norm(block.pose[:2, 3] - estimate.position[:2])
        )
        position_error, yaw_error = errors(estimate, nearest)
        assert position_error < POSITION_TOLERANCE and yaw_error < YAW_TOLERANCE, estimate


def test_the_default_burst_fails_every_block(board):
    world = World(seed=8)
    estimates = locate_blocks(
        DepthCamera(seed=8, faults=CameraFaults(bursts=(NoiseBurst(0.0, 1.0),))).capture(world), board
    )
    assert estimates and not any(estimate.ok for estimate in estimates)


def test_a_block_that_tipped_off_a_peg_top_is_found_beside_that_peg(board):
    world = World(seed=9)
    driver = Driver(world)
    grasp = grasp_keyframes(world, 3, grasp_candidate_facing(world, 3, "PSM1"))
    up = lifted(world, grasp[-1])
    offset = world.blocks[3].pose[:2, 3] - grasp[-1].position[:2]  # from the jaw to the block's centre
    miss = world.cell.pegs.positions[6] + [0.0, 0.004] - offset  # the hole lands 4 mm off peg 6's axis
    over = Keyframe(np.array([miss[0], miss[1], up.position[2]]), up.yaw, up.jaw)
    events = driver.play(
        {"PSM1": [*grasp, up, over, Keyframe(over.position, over.yaw, motion_settings().transfer.jaw_open)]}
    )
    driver.play({"PSM1": [parked(world, "PSM1")]})
    assert events[-1].kind == "drop" and "off the top of peg 6" in events[-1].detail

    estimates = locate_blocks(DepthCamera(seed=9).capture(world), board)

    dropped = [estimate for estimate in estimates if estimate.peg is None]
    assert len(dropped) == 1 and dropped[0].ok, dropped
    assert errors(dropped[0], world.blocks[3])[0] < POSITION_TOLERANCE
    assert block_on_peg(estimates, 6) is None


def test_blocks_touching_across_neighbouring_pegs_are_told_apart(board):
    world = World(seed=0)
    for index, yaw_deg in ((0, 58.0), (2, 2.0)):  # corners pointing at each other across 17.7 mm
        world.blocks[index].pose = yaw_pose(world.blocks[index].pose[:3, 3], math.radians(yaw_deg))
    corners = [
        block.pose[:2, :2] @ world.cell.block.outline.T + block.pose[:2, 3:] for block in world.blocks[0:3:2]
    ]
    gap = np.linalg.norm(corners[0].T[:, None] - corners[1].T[None], axis=2).min()
    assert (
        gap < perception_settings().block.segment.cluster_distance
    )  # one cluster to DBSCAN: only the split can separate them

    estimates = locate_blocks(DepthCamera(seed=0).capture(world), board)

    for block in world.blocks:
        estimate = block_on_peg(estimates, block.peg)
        assert estimate is not None and estimate.ok
        position_error, yaw_error = errors(estimate, block)
        assert position_error < POSITION_TOLERANCE and yaw_error < YAW_TOLERANCE


def test_a_loose_block_against_a_block_on_a_peg_is_told_apart_from_it(board):
    world = World(seed=0)
    on_peg, loose = world.blocks[1], world.blocks[3]
    loose.peg = None  # fell between pegs 0 and 1, against the block on peg 1 (0.7 mm apart)
    beside = world.cell.pegs.positions[1] - [0.0152, 0.0]
    loose.pose = yaw_pose([beside[0], beside[1], on_peg.pose[2, 3]], yaw_of(loose.pose))

    estimates = locate_blocks(DepthCamera(seed=0).capture(world), board)

    assert len(estimates) == 6
    fallen = [estimate for estimate in estimates if estimate.peg is None]
    assert len(fallen) == 1 and fallen[0].ok, fallen
    assert errors(fallen[0], loose)[0] < POSITION_TOLERANCE
    held = block_on_peg(estimates, 1)
    assert held is not None and held.ok, held
    position_error, yaw_error = errors(held, on_peg)
    assert position_error < POSITION_TOLERANCE and yaw_error < YAW_TOLERANCE


# Handover, seed 1001, a slip 0.70 s after PSM2's lift (repick15's scripted drop): the block from peg 0 came
# to rest flat here, against peg 3's block, in the cells of pegs 3, 6 and 9; the arms parked.
SLIPPED_AT = np.array([0.054685, 0.029651])
SLIPPED_YAW = math.radians(79.16)


@pytest.mark.parametrize("seed", [17, 25])  # of captures 0-39, the two whose noise let the crop pass at main
def test_a_loose_block_across_pegs_cells_is_found_whole_not_as_pieces(board, seed):
    """The per-peg crop cuts the loose block into three; peg 3's part, its block and a slice of the loose
    one, can still fit (88 %), and each other piece (~400 points) fits a whole block: two blocks that are
    not there, which the giver went for. A part off its own peg sends the cluster to be taken apart."""
    world = World(seed=1001)
    loose = world.blocks[0]
    loose.peg = None
    loose.pose = yaw_pose([*SLIPPED_AT, world.blocks[3].pose[2, 3]], SLIPPED_YAW)

    estimates = locate_blocks(DepthCamera(seed=seed).capture(world), board)

    assert len(estimates) == 6, estimates
    fallen = [estimate for estimate in estimates if estimate.peg is None]
    assert len(fallen) == 1 and fallen[0].ok, fallen
    position_error, yaw_error = errors(fallen[0], loose)
    assert position_error < POSITION_TOLERANCE and yaw_error < YAW_TOLERANCE
    for block in world.blocks[1:]:
        estimate = block_on_peg(estimates, block.peg)
        assert estimate is not None and estimate.ok, (block.index, estimate)
        assert errors(estimate, block)[0] < POSITION_TOLERANCE, block.index


def test_two_loose_blocks_touching_between_empty_pegs_are_never_reported_twice(board):
    """No peg holds a block in the cluster, so nothing takes it apart: the crop cuts the block at (78.0, 37.5)
    mm in half where the cells of pegs 9 and 11 meet, and each half fitted the whole block, twice the
    same block. Pieces off their own pegs are doubtful: a look again, not a grasp at a block reported twice."""
    world = World(seed=9)
    for block, (x, y, yaw_deg) in zip(world.blocks, ((0.08425, 0.02213, -149.75), (0.07799, 0.0375, 119.75))):
        block.pose, block.peg = yaw_pose([x, y, world.blocks[2].pose[2, 3]], math.radians(yaw_deg)), None

    estimates = locate_blocks(DepthCamera(seed=9).capture(world), board)

    loose = [estimate for estimate in estimates if estimate.peg is None]
    assert len(loose) >= 2, estimates  # seen, if doubtfully
    trusted = [estimate for estimate in loose if estimate.ok]
    assert all(
        min(errors(estimate, block)[0] for block in world.blocks[:2]) < POSITION_TOLERANCE
        for estimate in trusted
    ), trusted
    nearest = [min(range(2), key=lambda i: errors(estimate, world.blocks[i])[0]) for estimate in trusted]
    assert len(set(nearest)) == len(nearest), trusted  # no block twice
    assert sorted(estimate.peg for estimate in estimates if estimate.peg is not None) == [2, 3, 4, 5]


@pytest.mark.parametrize("seed", [0, 3])
def test_a_block_dropped_onto_a_peg_that_holds_one_is_found_on_top_of_it(board, seed):
    """A block that slipped over peg 6 while peg 6 held a block rests on that block: it is found there, on
    peg 6, one block up, and is the one `block_on_peg` offers (the only one that can be lifted off)."""
    world = World(seed=seed)
    world._rest_on_peg(world.blocks[0], 6, 0.3)
    dropped = world.blocks[1]
    dropped.pose = yaw_pose([*world.cell.pegs.positions[6], world.cell.pegs.top_z - 0.02], -0.4 + 0.3 * seed)
    dropped.peg = None
    world._settle(dropped, "PSM1", deliberate=False)
    assert world.events[-1].detail == "onto peg 6"  # it came down around peg 6, onto block 0
    estimates = locate_blocks(DepthCamera(seed=seed).capture(world), board)
    top = block_on_peg(estimates, 6)
    assert top is not None and top.ok, top
    assert stack_level(top) == 1
    position_error, yaw_error = errors(top, dropped)
    assert position_error < POSITION_TOLERANCE and yaw_error < YAW_TOLERANCE


def test_the_block_on_top_of_a_stack_is_grasped_at_its_height_and_lifted_off_the_peg(board):
    """The grasp and lift planned from that estimate (`transfer_for`, as a pick does) take the top block,
    one block higher than a block on the board, clear of the peg; the block under it stays."""
    world = World(seed=0)
    world._rest_on_peg(world.blocks[0], 6, 0.3)
    world._rest_on_peg(world.blocks[1], 6, -0.4)
    top = block_on_peg(locate_blocks(DepthCamera(seed=0).capture(world), board), 6)
    skills = Skills("uncalibrated")
    grasp = skills.selectors["PSM1"].pick(top)
    waypoints = transfer_for(world.cell, skills.motion, "PSM1", board, top, grasp)
    to_board = world.cell.arm_to_board("PSM1")
    at_grasp, risen = (to_board @ pose for pose in waypoints.poses[:2])
    open_, closed = motion_settings().transfer.jaw_open, motion_settings().transfer.jaw_closed
    frames = [
        Keyframe(position, yaw_of(at_grasp), jaw)
        for position, jaw in (
            (risen[:3, 3], open_),
            (at_grasp[:3, 3], open_),
            (at_grasp[:3, 3], closed),
            (risen[:3, 3], closed),
        )
    ]
    events = Driver(world).play({"PSM1": frames})
    assert [
        (event.kind, event.block) for event in events if event.kind in ("grasp", "lift", "collision")
    ] == [("grasp", 1), ("lift", 1)]
    assert world.held_by("PSM1") == 1 and world.blocks[0].peg == 6


# Bilateral, injected faults, seed 1002: PSM2's block slipped off the top of peg 7 and came to rest flat on
# the board here while PSM1, its grasp at peg 3 missed, rose off it with its shaft between the camera and
# the block (PSM1's tip at this point as the recovery looked), hiding part of the block's top face.
DROPPED_AT = np.array([0.06514, 0.00878])
PSM1_RISING_AT = np.array([0.0479, 0.0340, -0.0261])


def test_a_dropped_block_partly_hidden_by_the_other_arm_is_found_picked_and_placed(board):
    """The top face's centroid and yaw, read off the part seen, put ICP's start ~3 mm and ~30° out; the
    fits from starts round it find the block (`BlockLocator.search_hidden`); the grasp and transfer planned
    from that estimate, as a pick again does, take it off the board and onto its peg."""
    world = World(seed=1002)
    driver = Driver(world)
    jaw_open = motion_settings().transfer.jaw_open
    grasp = grasp_keyframes(world, 0, grasp_candidate_facing(world, 0, "PSM2"))
    up = lifted(world, grasp[-1])
    over = up.position[:2] + DROPPED_AT - world.blocks[0].pose[:2, 3]
    above = Keyframe(np.array([over[0], over[1], up.position[2]]), up.yaw, up.jaw)
    events = driver.play({"PSM2": [*grasp, up, above, Keyframe(above.position, above.yaw, jaw_open)]})
    assert events[-1].kind == "drop" and world.blocks[0].state == "on_board", events[-1]
    assert np.linalg.norm(world.blocks[0].pose[:2, 3] - DROPPED_AT) < 0.001
    driver.play({"PSM2": [parked(world, "PSM2")], "PSM1": [Keyframe(PSM1_RISING_AT, 0.0, jaw_open)]})

    estimates = locate_blocks(DepthCamera(seed=1002).capture(world), board)
    driver.play({"PSM1": [parked(world, "PSM1")]})

    dropped = [estimate for estimate in estimates if estimate.peg is None and estimate.ok]
    assert len(dropped) == 1, estimates
    position_error, yaw_error = errors(dropped[0], world.blocks[0])
    assert position_error < POSITION_TOLERANCE and yaw_error < YAW_TOLERANCE
    skills = Skills("uncalibrated")
    grasp_chosen = skills.selectors["PSM2"].pick(dropped[0])
    waypoints = transfer_for(world.cell, skills.motion, "PSM2", board, dropped[0], grasp_chosen, place_peg=0)
    at_grasp, risen, over_goal, lowered = (world.cell.arm_to_board("PSM2") @ pose for pose in waypoints.poses)
    yaw, closed = yaw_of(at_grasp), motion_settings().transfer.jaw_closed
    frames = [
        Keyframe(pose[:3, 3], yaw, jaw)
        for pose, jaw in (
            (risen, jaw_open),
            (at_grasp, jaw_open),
            (at_grasp, closed),
            (risen, closed),
            (over_goal, closed),
            (lowered, closed),
            (lowered, jaw_open),
            (over_goal, jaw_open),
        )
    ]
    events = driver.play({"PSM2": frames})
    assert [(event.kind, event.block, event.peg) for event in events if event.kind != "lift"] == [
        ("grasp", 0, None),
        ("release", 0, 0),
        ("place", 0, 0),
    ]


def test_a_block_a_jaw_holds_above_the_board_is_not_taken_for_one_lying_loose(board):
    """A pick again looks for a block off the pegs: the other arm's carried block, seen whole and flat, has
    nothing under it (`BlockLocator.resting`), so it is reported doubtful, never offered as one to pick."""
    world = World(seed=3)
    grasp = grasp_keyframes(world, 2, grasp_candidate_facing(world, 2, "PSM2"))
    up = lifted(world, grasp[-1])
    Driver(world).play({"PSM2": [*grasp, up, Keyframe(up.position + [0.005, 0.0, 0.0], up.yaw, up.jaw)]})
    assert world.held_by("PSM2") == 2

    estimates = locate_blocks(DepthCamera(seed=3).capture(world), board)

    held = [estimate for estimate in estimates if estimate.peg is None]
    assert len(held) == 1 and not held[0].ok, held
    assert np.linalg.norm(held[0].position[:2] - world.blocks[2].pose[:2, 3]) < POSITION_TOLERANCE
    assert held[0].reason.startswith("nothing under it: its bottom"), held[0].reason
