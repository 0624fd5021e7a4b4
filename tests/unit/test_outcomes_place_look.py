"""The paper's look at the held block before lowering it (`placelook`, the phase simulator's paper protocol):
the camera must see the block in `find_block_servo`'s box, and the arm then moves the block's seen bottom
over the peg, as imperfectly as the uncalibrated arm moves."""

from __future__ import annotations

import numpy as np
import pytest

from pegbt.frames import yaw_pose
from pegbt.perception import servo
from pegbt.sim.world import World
from pegbt.sim2real.outcomes import attempt, phasesim, placelook
from pegbt.sim2real.outcomes.bench import Replay
from pegbt.sim2real.outcomes.transfer_order import transfers


def test_the_camera_sees_a_block_held_over_the_peg_and_nothing_over_an_empty_peg():
    world = World(0)
    empty = next(p for p in range(len(world.cell.pegs.positions)) if all(b.peg != p for b in world.blocks))
    assert placelook.visible_points(world, empty) == 0
    peg_xy = world.cell.pegs.positions[empty]
    assert not servo.correction(world.cell.board_to_arm("PSM1"), peg_xy, np.zeros(3), 0).any()
    x, y = world.cell.pegs.positions[empty]
    bottom = world.cell.board.surface_z - 0.038  # where the paper's carry stops it (board z runs down)
    world.blocks[0].pose = yaw_pose([x + 0.002, y - 0.001, bottom], 0.3)
    assert placelook.visible_points(world, empty) >= servo.MIN_POINTS


@pytest.fixture
def lowered(monkeypatch):
    """PSM2's bilateral transfer 1 of layout 0 (2 -> 6), registered, lowered with the look (`True`) or with
    fewer than `MIN_POINTS` seen (`False`): whether the arm still holds it on the peg, where the block is
    (board x, y) as it starts down from the stop after the look's move, and the correction commanded and
    the block's offset from the peg's axis at the stop (board)."""

    def run(look: bool) -> tuple[bool, np.ndarray, np.ndarray, np.ndarray]:
        world = World(0)
        arm, start, goal = transfers("bilateral")[1]
        block = next(b.index for b in world.blocks if b.peg == start)
        moves, offsets, after = [], [], []
        update = World.update

        def recorded(w: World, time: float, tools: dict) -> list:
            events = update(w, time, tools)
            if offsets:  # after the look: the block's bottom (board z runs down) as the arm moves it
                after.append(w.blocks[block].pose[:3, 3].copy())
            return events

        def correction(to_arm, peg_xy, seen, points):
            offsets.append(world.blocks[block].pose[:2, 3] - peg_xy)
            move = servo.correction(to_arm, peg_xy, seen, points if look else servo.MIN_POINTS - 1)
            moves.append(to_arm[:3, :3].T @ move)
            return move

        monkeypatch.setattr(attempt, "correction", correction)
        monkeypatch.setattr(World, "update", recorded)
        rng = np.random.default_rng([0, 7])
        skills = phasesim._skills("uncalibrated")
        bench = attempt.pick_and_carry(
            world, skills, arm, block, goal, rng, None, Replay(), "bilateral", registered=True
        )
        assert len(moves) == 1
        stop = after[0][2]
        going_down = next(bottom for bottom in after if bottom[2] > stop + 0.001)
        return bool(bench.held), going_down[:2], moves[0][:2], offsets[0]

    return run


def test_the_look_moves_the_block_by_its_seen_offset_from_the_peg_up_to_the_arm_s_physics(lowered):
    """At the stop the block hangs 5 mm off the peg's axis; the look commands that move back, and the block
    starts down that much from where it starts unlooked (the uncalibrated arm's own error in the short move
    within a tenth of it), and lands on the peg; seen through fewer than 400 points, nothing is corrected,
    and the block, lowered to PSM2's `height_drop` (z −0.135 m in its frame, 8 mm over peg 6's top: the
    block's bottom 2.5 mm under it), strikes the peg."""
    held, with_look, move, offset = lowered(True)
    unlooked_held, without, no_move, _ = lowered(False)
    assert np.linalg.norm(offset) > 0.003
    assert np.linalg.norm(move + offset) < 0.001  # seen with perception's 0.3 mm of noise a side
    assert not no_move.any()
    assert np.linalg.norm((with_look - without) - move) < 0.1 * np.linalg.norm(move)
    assert held and not unlooked_held
