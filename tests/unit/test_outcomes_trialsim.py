"""A trial's transfers in order on one world (`trialsim`): a pick goes after the block `select_grasp` would
choose among those lying about, a way back that finds its peg empty fetches the nearest loose block, and a
seed's transfer is the same however far its trial is played and whatever worlds share it (the memo keys on
the seed alone)."""

from __future__ import annotations

import logging

import numpy as np

from pegbt.frames import yaw_of, yaw_pose
from pegbt.sim.world import World
from pegbt.sim.world_effects import WorldEffects
from pegbt.sim2real.outcomes.phasesim import Replay, carry_out
from pegbt.sim2real.outcomes.trialsim import chosen_block, simulate_trial

WAY_BACK = 6  # the unilateral order's first way back: peg 7 to peg 1


def _on_board(world: World, block: int, xy: tuple[float, float]) -> None:
    lying = world.blocks[block]
    lying.pose = yaw_pose([*xy, world.cell.board.surface_z], yaw_of(lying.pose))
    lying.peg = None
    assert not world._touching_pegs(lying).any()  # where a fall would leave it: clear of every peg


def test_a_pick_goes_after_the_block_select_grasp_would_choose() -> None:
    world = World(0)
    assert chosen_block(world, 3, dropped=False) == 3  # its own peg's block, lost or not
    assert chosen_block(world, 7, dropped=False) is None  # an empty peg: nothing, until the block was lost
    assert chosen_block(world, 7, dropped=True) is None  # no block lies loose
    _on_board(world, 0, (0.100, 0.070))
    _on_board(world, 1, (0.078, 0.026))
    assert chosen_block(world, 7, dropped=True) == 1  # the loose block nearest peg 7 (78, 6.5 mm)
    assert chosen_block(world, 10, dropped=True) == 0  # nearest peg 10 (78, 57 mm)
    stacked = world.blocks[2]
    stacked.pose, stacked.peg = world.blocks[3].pose.copy(), 3
    stacked.pose[2, 3] -= world.cell.block.height  # on top of peg 3's block (board z points down)
    assert chosen_block(world, 3, dropped=False) == 2  # of a stack, the top one
    assert chosen_block(world, 7, dropped=True) == 1
    stacked.pose[:2, 3] = world.cell.pegs.positions[7] + [0.0, 0.004]
    assert chosen_block(world, 7, dropped=True) == 2  # a block on another block lies loose too


def test_a_way_back_that_finds_its_peg_empty_fetches_the_nearest_loose_block() -> None:
    """As `transfer_block` does: the pick from the empty peg fails (`sense`), the recovery looks again and
    picks the loose block nearest the peg, and places it."""
    logging.getLogger("pegbt").setLevel(logging.ERROR)
    world = World(0)
    _on_board(world, 0, (0.100, 0.070))
    _on_board(world, 1, (0.078, 0.026))
    rng = np.random.default_rng([0, WAY_BACK, 7])
    result = carry_out(world, "unilateral", "calibrated", WAY_BACK, Replay(), 4, False, rng, chosen_block)
    assert result.succeeded and result.phase == "sense"
    assert world.blocks[1].peg == 1 and world.blocks[0].peg is None


def test_a_seeds_transfer_is_the_same_however_far_its_trial_is_played_and_among_other_worlds() -> None:
    logging.getLogger("pegbt").setLevel(logging.ERROR)
    bending = WorldEffects.of({"peg_compliance": {"deflection": 0.0015}})
    worlds = [WorldEffects(), bending, WorldEffects.of({"registration_offset": {"x": 0.002}})]
    together = simulate_trial(worlds, "unilateral", "uncalibrated", 1, 4)
    alone = simulate_trial([bending], "unilateral", "uncalibrated", 1, 6)
    assert [row[1] for row in together] == [row[0] for row in alone[:4]]
    assert len({(row[0].succeeded, row[0].phase) for row in alone}) > 1  # the trial's transfers differ
