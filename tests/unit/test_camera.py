"""The simulated depth camera: what it sees, what it cannot see, its noise and its faults."""

import numpy as np
import pytest
from world_helpers import block_points, in_board

from pegbt.errors import PegbtError
from pegbt.sim.camera import BOARD_GREY, RED, TOOL_GREY, DepthCamera
from pegbt.sim.faults import CameraFaults, NoiseBurst
from pegbt.sim.scripted import Driver, grasp_candidate_facing, grasp_keyframes, parked, transfer_keyframes
from pegbt.sim.world import World
from pegbt.workcell import N_PEGS
from pegbt.yamlfile import parse_yaml


@pytest.fixture(scope="module")
def world():
    world = World(seed=1)
    Driver(world).play({"PSM1": [parked(world, "PSM1")]})  # both arms parked, away from the board
    return world


@pytest.fixture(scope="module")
def clean_camera():
    return DepthCamera(depth_noise=0.0)


def test_a_capture_shows_all_12_pegs_and_6_blocks_where_the_world_has_them(world):
    cloud = DepthCamera(seed=0).capture(world)
    assert cloud.dtype == np.float32 and cloud.ndim == 2 and cloud.shape[1] == 3
    assert 0.4 < np.median(cloud[:, 2]) < 0.7  # camera frame: depth along z, about half a metre
    points = in_board(world.cell, cloud)
    for peg in range(N_PEGS):
        assert np.sum(np.linalg.norm(points - world.cell.pegs.top(peg), axis=1) < 0.002) >= 30, peg
    for block in world.blocks:
        assert len(block_points(world.cell, points, block.pose)) >= 1000, block.index


def test_a_moved_block_is_seen_at_its_new_peg():
    world = World(seed=2)
    Driver(world).play({"PSM1": transfer_keyframes(world, 1, 7, grasp_candidate_facing(world, 1, "PSM1"))})
    Driver(world).play({"PSM1": [parked(world, "PSM1")]})
    points = in_board(world.cell, DepthCamera(seed=0).capture(world))
    assert world.blocks[1].peg == 7
    assert len(block_points(world.cell, points, world.blocks[1].pose)) >= 1000
    # nothing block-shaped is left around peg 1: only its peg, the board and the neighbours' edges
    near_peg_1 = np.linalg.norm(points[:, :2] - world.cell.pegs.positions[1], axis=1) < 0.005
    raised = points[:, 2] < world.cell.board.surface_z - 0.002
    off_peg = (
        np.linalg.norm(points[:, :2] - world.cell.pegs.positions[1], axis=1) > world.cell.pegs.radius + 0.001
    )
    assert not np.any(near_peg_1 & raised & off_peg)


def test_faces_turned_away_and_the_board_behind_blocks_are_not_seen(world, clean_camera):
    points = in_board(world.cell, clean_camera.capture(world))
    camera_at = world.cell.camera.board_from_camera[:3, 3]
    model = world.cell.block
    normals, offsets = model.outline_planes
    for block in world.blocks:
        local = block_points(world.cell, points, block.pose)
        below_top = local[:, 2] > -model.height + 1e-5
        wall = (np.abs((local[:, :2] @ normals.T - offsets).max(axis=1)) < 1e-5) & below_top
        facing = normals[np.argmax(local[:, :2] @ normals.T - offsets, axis=1)]
        eye = (camera_at - block.pose[:3, 3]) @ block.pose[:3, :3]
        towards_eye = np.einsum("ij,ij->i", facing, eye[:2] - local[:, :2])
        assert np.any(wall & (towards_eye > 0))  # walls turned to the camera are seen ...
        assert not np.any(wall & (towards_eye < -1e-4))  # ... walls turned away are not
    # board points whose line of sight crosses a block's top face would be seen through the block
    board_points = points[np.abs(points[:, 2] - world.cell.board.surface_z) < 1e-6]
    shadowed = 0
    for block in world.blocks:
        top_z = block.pose[2, 3] - model.height
        f = (top_z - camera_at[2]) / (board_points[:, 2] - camera_at[2])
        crossing = camera_at + f[:, None] * (board_points - camera_at)
        local = (crossing - block.pose[:3, 3]) @ block.pose[:3, :3]
        solid = ((local[:, :2] @ normals.T - offsets).max(axis=1) < -1e-5) & (
            np.linalg.norm(local[:, :2], axis=1) > model.hole_radius + 1e-5
        )
        shadowed += int(solid.sum())
        # and the shadow is really there: board just behind the block (away from the camera) is missing
        behind = block.pose[:2, 3] + [0.0, -model.edge_distance - 0.003]
        assert not np.any(np.linalg.norm(board_points[:, :2] - behind, axis=1) < 0.0005)
    assert shadowed == 0


def test_noise_is_about_0_3_mm_along_the_rays_and_repeats_per_seed(world, clean_camera):
    clean = clean_camera.capture(world)
    noisy = DepthCamera(seed=3).capture(world)
    assert clean.shape == noisy.shape  # noise moves points along their rays, it does not add or hide any
    error = noisy[:, 2].astype(float) - clean[:, 2]
    assert np.std(error) == pytest.approx(0.0003, rel=0.05)
    assert np.array_equal(noisy, DepthCamera(seed=3).capture(world))
    assert not np.array_equal(noisy, DepthCamera(seed=4).capture(world))


def test_a_tool_gripping_a_block_hides_part_of_it():
    arms = World(seed=1)
    driver = Driver(arms)
    candidates = arms.cell.block.grasp_candidates.positions
    facing_camera = int(np.argmax((candidates[:, :2] @ arms.blocks[2].pose[:2, :2].T)[:, 1]))  # nearest +y
    driver.play({"PSM2": grasp_keyframes(arms, 2, facing_camera)})
    assert arms.held_by("PSM2") == 2
    seen_with = block_points(
        arms.cell, in_board(arms.cell, DepthCamera(seed=0).capture(arms)), arms.blocks[2].pose
    )
    seen_without = block_points(
        arms.cell,
        in_board(arms.cell, DepthCamera(seed=0, include_arms=False).capture(arms)),
        arms.blocks[2].pose,
    )
    assert len(seen_with) < 0.9 * len(seen_without)


def test_a_scheduled_noise_burst_is_noisy_and_logged(world, clean_camera):
    camera = DepthCamera(
        seed=0, faults=CameraFaults(bursts=(NoiseBurst(start=10.0, duration=1.0, sigma=0.003),))
    )
    clean = clean_camera.capture(world)
    before = len(world.events)
    quiet = camera.capture(world, time=9.0)
    assert len(world.events) == before
    burst = camera.capture(world, time=10.5)
    assert [event.kind for event in world.events.since(before)] == ["fault"]
    assert "depth noise burst" in world.events[-1].detail and world.events[-1].time == 10.5
    assert np.std(burst[:, 2] - clean[:, 2]) > 5 * np.std(quiet[:, 2] - clean[:, 2])


def test_camera_faults_from_configuration_and_their_errors():
    faults = CameraFaults.read(
        parse_yaml("bursts: [{start: 1, duration: 0.5}]\nburst_probability: 0.1", "sim.yaml")
    )
    assert faults.bursts == (NoiseBurst(1.0, 0.5),) and faults.burst_probability == 0.1
    with pytest.raises(PegbtError) as caught:
        CameraFaults.read(parse_yaml("bursts: [{start: 1}]", "sim.yaml"))
    assert caught.value.field == "bursts[0].duration" and caught.value.file == "sim.yaml"
    with pytest.raises(PegbtError):
        CameraFaults.read(parse_yaml("burst_probability: 1.5", "sim.yaml"))


def test_each_point_has_the_colour_of_what_its_ray_met():
    """A tool gripping a block: the block's points red, the tool's dark grey, the bare board light grey,
    in the same order as the points; a pixel that saw nothing has no colour."""
    arms = World(seed=1)
    candidates = arms.cell.block.grasp_candidates.positions
    facing_camera = int(np.argmax((candidates[:, :2] @ arms.blocks[2].pose[:2, :2].T)[:, 1]))
    Driver(arms).play({"PSM2": grasp_keyframes(arms, 2, facing_camera)})
    camera = DepthCamera(seed=0)
    points, rgba = camera.capture_coloured(arms)
    assert np.array_equal(points, DepthCamera(seed=0).capture(arms)) and rgba.shape == (len(points),)
    board = in_board(arms.cell, points)
    pose, raised = arms.blocks[2].pose, arms.cell.board.surface_z - board[:, 2] > 0.001  # board z down
    on_block = len(block_points(arms.cell, board[raised], pose))
    red_on_block = len(block_points(arms.cell, board[raised & (rgba == RED)], pose))
    assert on_block > 500 and red_on_block > 0.98 * on_block  # the rest: the jaw, within 0.5 mm of a wall
    tool = arms.tools["PSM2"]
    shaft_axis = tool.shaft[1] - tool.shaft[0]
    along = (board - tool.shaft[0]) @ shaft_axis / (shaft_axis @ shaft_axis)
    nearest = tool.shaft[0] + np.clip(along, 0, 1)[:, None] * shaft_axis
    on_shaft = np.linalg.norm(board - nearest, axis=1) < arms.cell.tool.shaft_radius + 0.0005
    assert on_shaft.sum() > 100 and set(rgba[on_shaft]) == {TOOL_GREY}
    bare = np.abs(board[:, 2] - arms.cell.board.surface_z) < 0.0005
    assert set(rgba[bare & (rgba != RED)]) == {BOARD_GREY}
    exposure = camera.expose(arms)
    exposure.cast(camera.ray_count)
    organised = exposure.colours()
    assert np.array_equal(organised == 0, ~np.isfinite(exposure.points()[:, 0]))
