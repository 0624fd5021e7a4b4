"""The phase simulator recovers a handover giver's fallen block as the trees do (`trees/shared/set_back.yaml`):
where no grasp is both clear of the pegs and one the receiver can take, it sets the block back on its start
peg and hands it over from there; under the paper's protocol (one attempt) it gives up, as that robot did."""

from __future__ import annotations

import numpy as np
import pytest

from pegbt.frames import yaw_pose
from pegbt.sim.world import World
from pegbt.sim.world_effects import WorldEffects
from pegbt.sim2real.outcomes.bench import Replay
from pegbt.sim2real.outcomes.phasesim import REGRASPS, carry_out
from pegbt.sim2real.outcomes.transfer_order import transfers
from pegbt.sim2real.outcomes.transfer_result import TransferResult

# seed 1001's handover 2 with `--inject-faults` (`tests/unit/test_set_back.py`): the block PSM2 carried from
# peg 0 lay 11 mm beside peg 3 (board frame, m; yaw, rad)
DROPPED = ((0.05547, 0.03004), -0.71995)
INDEX = 1  # the handover PSM2 gives from peg 0 to PSM1 for peg 6


def _dropped(seed: int) -> tuple[World, int]:
    world = World(seed, effects=WorldEffects())
    block = next(b for b in world.blocks if b.peg == transfers("handover")[INDEX][1])
    (x, y), yaw = DROPPED
    block.pose = yaw_pose([x, y, world.cell.board.surface_z], yaw)
    block.peg = None
    return world, block.index


def _carried(seed: int, attempts: int) -> tuple[TransferResult, World, int]:
    world, block = _dropped(seed)
    rng = np.random.default_rng([seed, 7])
    result = carry_out(
        world, "handover", "optimized", INDEX, Replay(), attempts, False, rng, pick=lambda *_: block
    )
    return result, world, block


@pytest.mark.parametrize("seed", [0, 1])
def test_a_fallen_block_with_no_grasp_to_hand_over_is_set_back_and_handed_over(seed: int) -> None:
    result, world, block = _carried(seed, 1 + REGRASPS)
    assert result.succeeded and result.phase is None
    assert world.blocks[block].peg == transfers("handover")[INDEX][2]
    kinds = [e.kind for e in world.events]
    assert kinds.count("place") == 2  # on its start peg, then on its goal peg
    assert "collision" not in kinds


def test_the_papers_one_attempt_gives_up_on_it() -> None:
    result, world, block = _carried(0, 1)
    assert not result.succeeded and result.phase == "sense"
    assert world.blocks[block].peg is None
