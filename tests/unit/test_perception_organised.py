"""Block search on an organised capture (a Zivid's): only the pixels near something raised off the board,
at full resolution, finding what a search of every point finds."""

from dataclasses import dataclass

import numpy as np
import pytest

from pegbt.perception.blocks import block_on_peg, locate_blocks
from pegbt.perception.board import PegboardRegistration
from pegbt.perception.organised import OrganisedCloud
from pegbt.sim.camera import DepthCamera
from pegbt.sim.world import World


@dataclass
class Image:
    grid: np.ndarray


@pytest.fixture(scope="module")
def board():
    board = PegboardRegistration().fit(DepthCamera(seed=99).capture(World(seed=0)))
    assert board.ok, board.reason
    return board


@pytest.mark.parametrize("seed", [0, 3])
def test_an_organised_capture_finds_every_block_as_a_search_of_every_point_does(board, seed):
    world = World(seed=seed)
    camera = DepthCamera(seed=seed)
    grid = camera.capture_organised(world).reshape(*camera.image_shape, 3)
    assert isinstance(Image(grid), OrganisedCloud)
    every_point = locate_blocks(grid[np.isfinite(grid).all(axis=2)], board)
    organised = locate_blocks(Image(grid), board)
    assert len(organised) == len(every_point) == 6
    for block in world.blocks:
        near, far = block_on_peg(organised, block.peg), block_on_peg(every_point, block.peg)
        assert near is not None and near.ok and far is not None, block.index
        assert np.linalg.norm(near.position - block.pose[:3, 3]) < 0.0003, block.index
        assert np.linalg.norm(near.position - far.position) < 0.0001, block.index


def test_an_image_with_nothing_raised_has_no_block(board):
    grid = np.full((60, 80, 3), np.nan, dtype=np.float32)
    assert locate_blocks(Image(grid), board) == []
