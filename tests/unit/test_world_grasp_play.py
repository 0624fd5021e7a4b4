"""Jaws closing on a wall its peg holds push the tip aside within the wrist's cable play (`ToolState.give`),
as a peg pressing on a held block does: a grasp further off the wall's centre than the block can slide on
its peg grips when the play on the side the tip is pushed takes the rest, and misses when it does not."""

import numpy as np
from world_effects_helpers import YieldingDriver, grasp_block, outward

from pegbt.sim.world import World
from pegbt.sim.world_effects import WorldEffects

# m further out than the grasp candidate (itself 0.4 mm out): 2.4 mm off the wall's centre, where the peg
# stops the block 0.4 mm short of centring the wall between the jaws
OFF_CENTRE = 0.002
PLAY = 0.0006  # m of the wrist's play on one side


def _grasp(give, effects=WorldEffects()):
    world = World(1, effects=effects)
    driver = YieldingDriver(world, give)
    events, _ = grasp_block(world, driver, 1, error=OFF_CENTRE * outward(world))
    return world, [event.kind for event in events], events


def _sides():
    """The give with the play on the side the wall pushes the tip (inward, towards the hole), and on the
    other side."""
    world = World(1)
    driver = YieldingDriver(world, (0.0,) * 4)
    _, frame = grasp_block(world, driver, 1, error=OFF_CENTRE * outward(world))
    tip_x = driver.tool("PSM1", frame).tip[:2, 0]
    inward_is_plus_x = float(-outward(world)[:2] @ tip_x) > 0
    plus, minus = (0.0, PLAY, 0.0, 0.0), (PLAY, 0.0, 0.0, 0.0)
    return (plus, minus) if inward_is_plus_x else (minus, plus)


def test_a_grasp_the_peg_stops_grips_within_the_wrist_s_play_on_the_side_the_wall_pushes_the_tip():
    _, rigid, events = _grasp((0.0,) * 4)
    assert rigid == ["grasp_miss"] and "peg 1 stops the block" in events[0].detail

    pushed, other = _sides()
    world, kinds, _ = _grasp(pushed)
    assert kinds == ["grasp"] and world.held_by("PSM1") == 1
    hole = world.blocks[1].pose[:2, 3] - world.cell.pegs.positions[1]
    assert np.linalg.norm(hole) < 0.002 + 1e-5  # slid only until the peg stopped it

    _, kinds, _ = _grasp(other)  # cable play on the other side takes nothing of the push
    assert kinds == ["grasp_miss"]


def test_the_capture_width_takes_only_what_the_play_leaves():
    pushed, _ = _sides()
    short = tuple(value / 2 for value in pushed)  # 0.3 mm of play: 0.1 mm of the 0.4 mm left over
    _, kinds, _ = _grasp(short)
    assert kinds == ["grasp_miss"]
    _, kinds, _ = _grasp(short, WorldEffects.of({"grasp_capture": {"width": 0.00015}}))
    assert kinds == ["grasp"]
    _, kinds, _ = _grasp((0.0,) * 4, WorldEffects.of({"grasp_capture": {"width": 0.00015}}))
    assert kinds == ["grasp_miss"]
