"""World effects on what the robot reaches and what the camera measures: the scene places each arm's tool
by the world's (registration-offset) base, and a depth bias moves what perception locates along the rays,
never the world's truth."""

import numpy as np
import pytest

from pegbt.evaluation.trial import TrialSpec, simulator_args
from pegbt.motion.limits import arm_settings
from pegbt.perception.blocks import locate_blocks
from pegbt.perception.board import PegboardRegistration
from pegbt.physics import ArmPhysics
from pegbt.sim.arm import SimArm
from pegbt.sim.camera import DepthCamera, view_error
from pegbt.sim.log import SimLog
from pegbt.sim.scene import Scene
from pegbt.sim.world import World
from pegbt.sim.world_effects import WorldEffects


def test_the_scene_puts_each_tool_where_the_offset_base_puts_it():
    tips = []
    for effects in (WorldEffects(), WorldEffects.of({"registration_offset": {"x": 0.002, "z": -0.001}})):
        world = World(0, effects=effects)
        scene = Scene(world, {"PSM1": SimArm("PSM1", arm_settings("PSM1"), ArmPhysics())}, SimLog())
        scene.update(0.01)
        tips.append(world.tools["PSM1"].tip[:3, 3])
    assert np.allclose(tips[1] - tips[0], [0.002, 0.0, -0.001])


def _located_minus_truth(effects):
    """Perception's located block on the board less where it truly is (board frame), and the world's truth."""
    world = World(3, effects=effects)
    block = world.blocks[1]
    block.peg, block.pose[:2, 3] = None, [0.030, 0.065]  # on the board, clear of the pegs
    cloud = DepthCamera(seed=3, include_arms=False).capture(world)
    board = PegboardRegistration().fit(cloud)
    assert board.ok, board.reason  # the pegboard is measured true: its registration holds
    located = min(
        locate_blocks(cloud, board), key=lambda b: np.linalg.norm(b.position[:2] - block.pose[:2, 3])
    )
    return located.position - block.pose[:3, 3], world.block_poses()


@pytest.mark.parametrize("bias", [0.003, -0.002])
def test_a_depth_bias_moves_what_perception_locates_along_the_camera_s_rays_and_not_the_world(bias):
    unbiased, truth = _located_minus_truth(WorldEffects())
    biased, biased_truth = _located_minus_truth(WorldEffects.of({"depth_bias": {"bias": bias}}))
    assert np.linalg.norm(unbiased) < 0.0003
    cell = World(3).cell
    ray = np.array([0.030, 0.065, cell.board.surface_z]) - cell.camera.board_from_camera[:3, 3]
    assert np.allclose(biased, bias * ray / np.linalg.norm(ray), atol=0.0004)  # 0.3 mm noise, a block's ICP
    assert np.array_equal(truth, biased_truth)


def test_eval_hands_the_world_file_to_a_simulator_it_starts(tmp_path):
    spec = TrialSpec("unilateral", "optimized", 3, tmp_path / "t.jsonl", world_effects=tmp_path / "w.yaml")
    args = simulator_args(spec, tmp_path / "truth.jsonl")
    assert args[args.index("--world-effects") + 1] == str(tmp_path / "w.yaml")
    assert "--world-effects" not in simulator_args(
        TrialSpec("unilateral", "optimized", 3, tmp_path / "t"), tmp_path
    )


def test_a_dask_worker_that_cannot_see_the_client_s_files_gets_the_world_file_s_text(tmp_path, monkeypatch):
    from pegbt.evaluation import cluster

    seen = {}

    def run_trial(spec):
        seen["text"] = spec.world_effects.read_text()
        return cluster.TrialRecord(spec.variant, spec.condition, spec.seed, "success")

    monkeypatch.setattr(cluster, "run_trial", run_trial)
    text = "effects:\n  - {kind: depth_bias, bias: 0.001}\n"
    spec = TrialSpec(
        "unilateral", "optimized", 3, tmp_path / "t.jsonl", world_effects=tmp_path / "client-only.yaml"
    )
    task = cluster.RemoteTrial(spec, None, cluster.this_checkout(), None, "token", text)
    cluster.run_remote_trial(task)
    assert seen["text"] == text


def _capture_of_a_block_on_the_board(effects, at=(0.030, 0.065), seed=3):
    """A capture (camera frame, every pixel) of world 3 with block 1 lying on the board at `at` (board x, y),
    and that world."""
    world = World(3, effects=effects)
    block = world.blocks[1]
    block.peg, block.pose[:2, 3] = None, at
    return DepthCamera(seed=seed, include_arms=False).capture_organised(world), world


def test_perception_noise_shows_each_block_off_as_one_piece_and_the_same_while_it_does_not_move():
    noisy = WorldEffects.of({"perception_noise": {"sd": 0.001}})
    plain, world = _capture_of_a_block_on_the_board(WorldEffects())
    shown, _ = _capture_of_a_block_on_the_board(noisy)
    again, _ = _capture_of_a_block_on_the_board(noisy)
    moved, _ = _capture_of_a_block_on_the_board(noisy, at=(0.031, 0.065))
    # the same rays meet the same surfaces, so a point's shift is what the camera added to it
    shift = (shown - plain)[np.isfinite(plain[:, 0])]
    in_board = shift @ world.cell.camera.board_from_camera[:3, :3].T
    offsets = np.unique(np.round(in_board, 6), axis=0)
    assert 2 <= len(offsets) <= 1 + len(world.blocks)  # the board and pegs stay; each block moves whole
    assert np.allclose(offsets[:, 2], 0.0)  # in the board's plane
    assert np.count_nonzero(np.abs(offsets[:, :2]) > 0.0001) > 2  # millimetre draws, x and y
    assert np.array_equal(shown, again, equal_nan=True)  # an unmoved block is shown where it was
    assert not np.allclose(moved, shown, equal_nan=True)


def test_perception_locates_a_block_where_perception_noise_shows_it_and_the_world_keeps_its_truth():
    noisy = WorldEffects.of({"perception_noise": {"sd": 0.001}})
    plain, truth = _located_minus_truth(WorldEffects())
    off, noisy_truth = _located_minus_truth(noisy)
    world = World(3, effects=noisy)
    block = world.blocks[1]
    block.peg, block.pose[:2, 3] = None, [0.030, 0.065]
    expected = view_error(3, block.pose, 0.001)
    assert np.linalg.norm(expected[:2]) > 0.0005  # a draw large enough to see
    assert np.allclose(off[:2] - plain[:2], expected[:2], atol=0.0002)
    assert np.array_equal(truth, noisy_truth)


def test_a_world_without_perception_noise_is_captured_as_before():
    plain, _ = _capture_of_a_block_on_the_board(WorldEffects())
    inert, _ = _capture_of_a_block_on_the_board(WorldEffects.of({"perception_noise": {"sd": 0.0}}))
    assert np.array_equal(plain, inert, equal_nan=True)
