"""What setting a dropped block back on its start peg rests on (`trees/shared/set_back.yaml`): a block the
giver dropped beside a peg may have grasps clear of the pegs and grasps the receiver can take, but none both;
on its start peg, at any yaw, it has one both clear and handed."""

from __future__ import annotations

import math

import numpy as np
import pytest

from pegbt.behaviours.actions.handover import handed
from pegbt.behaviours.resources.skills import Skills
from pegbt.motion.ik import solve_ik
from pegbt.motion.peg_clearance import tool_peg_gap
from pegbt.perception.blocks import BlockEstimate
from pegbt.perception.grasp import YAW_WINDOW, grasp_options

# seed 1001's handover 2 with `--inject-faults`: the block from peg 0 as PSM2's look located it (board frame,
# m; yaw, rad), 11 mm beside peg 3
DROPPED = ((0.05547, 0.03004), -0.71995)
YAWS = np.radians(np.arange(-60, 60, 10))  # a block's yaw is known modulo 120°


@pytest.fixture(scope="module")
def skills() -> Skills:
    return Skills("optimized", variant="handover")


def _block(skills: Skills, xy, yaw: float, peg: int | None) -> BlockEstimate:
    return BlockEstimate(
        np.array([*xy, skills.cell.board.surface_z]), float(yaw), peg, 1.0, 3e-4, 1000, True, ""
    )


def _to_give(skills: Skills, giver: str, receiver: str, block: BlockEstimate):
    selector = skills.selectors[giver]
    return selector.pick(block, acceptable=lambda option: handed(skills, giver, receiver, block, option))


def test_the_dropped_block_has_a_clear_grasp_and_a_handed_one_but_none_both(skills):
    block = _block(skills, *DROPPED, None)
    settings, board_from_arm = skills.arm("PSM2").settings, skills.cell.arm_to_board("PSM2")
    clear, handed_over = set(), set()
    for option in grasp_options(block.pose, "PSM2", skills.cell):
        if abs(option.yaw) > YAW_WINDOW:
            continue
        q = solve_ik(option.pose, settings)
        if float(tool_peg_gap(q, board_from_arm, skills.cell)) >= 0.0:
            clear.add(option.candidate)
        if handed(skills, "PSM2", "PSM1", block, option):
            handed_over.add(option.candidate)
    assert clear and handed_over and not clear & handed_over
    assert _to_give(skills, "PSM2", "PSM1", block) is None
    assert skills.selectors["PSM2"].pick(block) is not None  # it can be set back


@pytest.mark.parametrize("giver", ["PSM2", "PSM1"])
def test_a_block_on_its_start_peg_has_a_clear_grasp_the_receiver_can_take_at_any_yaw(skills, giver):
    receiver = "PSM1" if giver == "PSM2" else "PSM2"
    left = skills.cell.pegs.left_group
    pegs = (
        left
        if giver == "PSM2"
        else [peg for peg in range(len(skills.cell.pegs.positions)) if peg not in left]
    )
    missing = [
        (peg, round(math.degrees(yaw)))
        for peg in pegs
        for yaw in YAWS
        if _to_give(skills, giver, receiver, _block(skills, skills.cell.pegs.positions[peg], yaw, peg))
        is None
    ]
    assert missing == []
