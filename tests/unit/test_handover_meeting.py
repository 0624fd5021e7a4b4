"""Planning the meeting: the receiver's grasp keeps its tool clear of the giver's (as the simulator's world
judges contact), and a giver picks only grasps from which the block can be handed over."""

from __future__ import annotations

import math

import numpy as np
import pytest

from pegbt.behaviours.meeting import plan_meeting
from pegbt.behaviours.resources.skills import Skills
from pegbt.motion.handover import tool_gap
from pegbt.motion.ik import solve_ik
from pegbt.perception.blocks import BlockEstimate
from pegbt.sim.tools import ToolState
from pegbt.sim.world import World

SKILLS = Skills("uncalibrated")
CELL = SKILLS.cell


def block_at(x: float, y: float, yaw_deg: float, peg: int | None = None) -> BlockEstimate:
    return BlockEstimate(
        np.array([x, y, CELL.board.surface_z]), math.radians(yaw_deg), peg, 1.0, 0.0003, 1000, True, ""
    )


def world_sees_tools_touch(q_a, arm_a, q_b, arm_b) -> bool:
    """Whether the simulator's world logs a tool-tool or shaft-shaft contact with the arms at these joints."""
    world = World(seed=0)
    world.update(
        0.01,
        {
            arm: ToolState.from_joints(np.asarray(q), 0.8, CELL.arm_to_board(arm))
            for arm, q in ((arm_a, q_a), (arm_b, q_b))
        },
    )
    return any(
        event.kind == "collision" and event.detail in ("tool-tool", "shaft-shaft") for event in world.events
    )


def test_tool_gap_is_negative_exactly_where_the_world_sees_the_tools_touch():
    rng = np.random.default_rng(3)
    meeting = solve_ik(
        plan_meeting(SKILLS, "PSM2", "PSM1", *pick_of("PSM2", 1)).tip, SKILLS.arm("PSM2").settings
    )
    checked = {True: 0, False: 0}
    for _ in range(60):
        tip = plan_meeting(SKILLS, "PSM2", "PSM1", *pick_of("PSM2", 1)).receiver_grasp.pose.copy()
        tip[:3, 3] += rng.uniform(-0.012, 0.012, 3)
        q = solve_ik(tip, SKILLS.arm("PSM1").settings)
        gap = float(tool_gap(q, CELL.board_to_arm("PSM1"), meeting, CELL.board_to_arm("PSM2"), CELL.tool))
        if abs(gap) > 1e-4:  # not grazing
            touching = world_sees_tools_touch(q, "PSM1", meeting, "PSM2")
            assert touching == (gap < 0), gap
            checked[touching] += 1
    assert checked[True] and checked[False]  # both sides were tried


def pick_of(arm: str, peg: int, seed: int = 2) -> tuple:
    """The paper's grasp by `arm` of a block on `peg`, turned as the seed turns the block it starts on the
    left peg of the same row (blocks come back to the left at the yaws they were placed with), and that block."""
    world = World(seed=seed)
    pose = world.blocks[min(peg % 6, 5)].pose
    x, y = CELL.pegs.positions[peg]
    block = BlockEstimate(
        np.array([x, y, pose[2, 3]]), math.atan2(pose[1, 0], pose[0, 0]), peg, 1.0, 0.0003, 1000, True, ""
    )
    return SKILLS.selectors[arm].pick(block), block


@pytest.mark.parametrize("seed", [0, 2, 5])
def test_every_block_picked_off_its_peg_meets_with_a_grasp_clear_of_the_giver(seed):
    for giver, receiver, pegs in (("PSM2", "PSM1", range(6)), ("PSM1", "PSM2", range(6, 12))):
        for peg in pegs:
            grasp, block = pick_of(giver, peg, seed)
            meeting = plan_meeting(SKILLS, giver, receiver, grasp, block)
            assert meeting is not None, (giver, peg)
            q_giver = solve_ik(meeting.tip, SKILLS.arm(giver).settings)
            q_receiver = solve_ik(meeting.receiver_grasp.pose, SKILLS.arm(receiver).settings)
            assert not world_sees_tools_touch(q_receiver, receiver, q_giver, giver)


def test_a_block_held_on_some_walls_cannot_be_handed_over_and_the_giver_picks_another_wall():
    """A block lying on the board between pegs 1 and 6 (where PSM1 drops one it carried): held on two of its
    walls, every grasp of PSM2 at the meeting point would strike PSM1's tool; the giver's pick avoids those.
    (It lies 10.7 mm from peg 6: at 2.2 mm, as it was, the grasps but one put PSM1's tool on that peg.)"""
    block = block_at(0.055, 0.0125, 0.0)
    feasible = SKILLS.selectors["PSM1"].feasible(block.pose)
    handed = {
        option.candidate: plan_meeting(SKILLS, "PSM1", "PSM2", option, block) is not None
        for option in feasible
    }
    assert not all(handed.values()) and any(handed.values()), handed
    chosen = SKILLS.selectors["PSM1"].pick(block, acceptable=lambda option: handed[option.candidate])
    assert handed[chosen.candidate]
    assert not handed[
        SKILLS.selectors["PSM1"].pick(block).candidate
    ]  # the paper's rule alone picks one of those
