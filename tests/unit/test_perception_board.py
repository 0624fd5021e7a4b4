"""Pegboard registration: a perturbed extrinsic is corrected, the pegs are found, bad clouds are refused."""

import math

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from pegbt.errors import PegbtError
from pegbt.perception.blocks import locate_blocks
from pegbt.perception.board import PegboardRegistration
from pegbt.sim.camera import DepthCamera
from pegbt.sim.faults import CameraFaults, NoiseBurst
from pegbt.sim.world import World


@pytest.fixture(scope="module")
def world():
    return World(seed=0)


@pytest.fixture(scope="module")
def cloud(world):
    return DepthCamera(seed=0).capture(world)


def peg_top_error(cell, board_from_camera):
    """Largest displacement (m) of a peg top between the true extrinsics and `board_from_camera`."""
    error = board_from_camera @ cell.camera.camera_from_board
    tops = cell.pegs.tops
    return np.linalg.norm(tops @ error[:3, :3].T + error[:3, 3] - tops, axis=1).max()


@pytest.fixture(scope="module")
def registration():
    return PegboardRegistration()


@pytest.fixture(scope="module")
def board(registration, cloud):
    return registration.fit(cloud)


@pytest.mark.parametrize(
    "rotation_deg, translation_mm",
    [
        ((2.0, 0.0, 0.0), (3.0, 0.0, 0.0)),
        ((0.0, -1.5, 2.0), (0.0, -3.0, 2.0)),
        ((-1.0, 1.0, -2.5), (-2.0, 2.0, -3.0)),
    ],
)
def test_a_perturbed_extrinsic_is_corrected_to_a_tenth_of_a_millimetre(
    world, cloud, rotation_deg, translation_mm
):
    perturbation = np.eye(4)
    perturbation[:3, :3] = Rotation.from_rotvec(np.radians(rotation_deg)).as_matrix()
    perturbation[:3, 3] = np.array(translation_mm) / 1000
    nominal = perturbation @ world.cell.camera.board_from_camera
    assert peg_top_error(world.cell, nominal) > 0.003

    board = PegboardRegistration(nominal_board_from_camera=nominal).fit(cloud)

    assert board.ok, board.reason
    assert peg_top_error(world.cell, board.board_from_camera) < 0.0001
    assert board.fitness > 0.7


def test_all_twelve_pegs_are_found_where_they_stand(world, board):
    assert board.ok, board.reason
    assert np.all(board.peg_points >= 50)
    assert np.abs(board.peg_tops - world.cell.pegs.tops).max() < 0.0002


def test_a_depth_noise_burst_fails_the_board_registration_explicitly(world):
    burst = CameraFaults(bursts=(NoiseBurst(start=0.0, duration=1.0),))
    board = PegboardRegistration().fit(DepthCamera(seed=3, faults=burst).capture(world))
    assert not board.ok
    assert "fits only" in board.reason


@pytest.mark.parametrize(
    "bad, field",
    [
        (np.zeros((0, 3)), "cloud"),
        (np.zeros((10, 2)), "cloud"),
        ("not a cloud", "cloud"),
        (np.array([[0.0, 0.0, 0.5], [np.nan, 0.0, 0.5], [0.0, 0.0, 0.5]]), "cloud[1]"),
        (np.array([[0.0, 0.0, np.inf]]), "cloud[0]"),
    ],
)
def test_bad_clouds_raise_a_pegbt_error_naming_the_field(registration, board, bad, field):
    with pytest.raises(PegbtError) as raised:
        registration.fit(bad)
    assert raised.value.field == field
    with pytest.raises(PegbtError) as raised:
        locate_blocks(bad, board)
    assert raised.value.field == field


def test_nan_points_are_refused_even_in_an_otherwise_good_capture(registration, cloud):
    spoiled = cloud.copy()
    spoiled[1234, 2] = math.nan
    with pytest.raises(PegbtError, match="not finite"):
        registration.fit(spoiled)


def test_a_cloud_that_does_not_show_the_board_is_a_failed_registration_not_a_crash(registration):
    rng = np.random.default_rng(0)
    scattered = rng.normal(0.0, 0.2, (500, 3))  # wild points only: nothing survives thinning
    far_wall = np.column_stack(
        [rng.uniform(-0.3, 0.3, 20000), rng.uniform(-0.3, 0.3, 20000), np.full(20000, 2.0)]
    )
    for cloud, reason in ((scattered, "not a view of the board"), (far_wall, "fits only 0%")):
        board = registration.fit(cloud)
        assert not board.ok and reason in board.reason
        with pytest.raises(PegbtError, match="board registration failed") as raised:
            locate_blocks(cloud, board)
        assert raised.value.field == "board"
