"""In lockstep, perception gives the same poses bit for bit each time it sees the same cloud: Open3D's
parallel sums otherwise add up in whatever order its threads finish, the board's pose moves by ~3e-8, and
a campaign on other processes (a Dask cluster) no longer equals the local one seed for seed."""

from types import SimpleNamespace

import numpy as np
import open3d as o3d
import pytest

from pegbt.behaviours.actions.sensing import FindBlocks, RegisterBoard
from pegbt.perception.blocks import BlockLocator
from pegbt.perception.board import PegboardRegistration
from pegbt.sim.camera import DepthCamera
from pegbt.sim.world import World

REPEATS = 5


@pytest.fixture(scope="module")
def cloud():
    return DepthCamera(seed=0).capture(World(seed=0))


def leaf(kind, inline: bool):
    """A sensing leaf as a run in lockstep (`inline`) or in real time builds it, with the real perception."""
    made = object.__new__(kind)
    made.context = SimpleNamespace(work=SimpleNamespace(inline=inline))
    made.skills = SimpleNamespace(registration=PegboardRegistration(), locator=BlockLocator())
    return made


def test_lockstep_registration_and_block_search_repeat_bit_for_bit(cloud):
    register, find = leaf(RegisterBoard, inline=True), leaf(FindBlocks, inline=True)
    boards = [register.compute(cloud) for _ in range(REPEATS)]
    for board in boards[1:]:
        np.testing.assert_array_equal(board.board_from_camera, boards[0].board_from_camera)
    found = [find.compute(cloud, boards[0]) for _ in range(REPEATS)]
    for blocks in found[1:]:
        for block, first in zip(blocks, found[0], strict=True):
            np.testing.assert_array_equal(block.position, first.position)
            assert block.yaw == first.yaw


def test_the_thread_limit_is_lifted_after_lockstep_perception_and_not_set_in_real_time(cloud):
    before = o3d.utility.get_max_threads()
    seen = []
    real_time = leaf(RegisterBoard, inline=False)
    real_time.skills.registration = SimpleNamespace(fit=lambda _: seen.append(o3d.utility.get_max_threads()))
    real_time.compute(cloud)
    lockstep = leaf(RegisterBoard, inline=True)
    lockstep.skills.registration = real_time.skills.registration
    lockstep.compute(cloud)
    assert seen == [before, 1] and o3d.utility.get_max_threads() == before
