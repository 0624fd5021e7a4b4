"""A grasp's tool keeps clear of the pegs: the shaft comes down leaning towards the arm's remote centre, so a
block a slip dropped beside a peg, gripped on its side facing that peg, brings the shaft's end onto the peg
(`--inject-faults`: seed 1001 at 13.88 and 28.26 s, seed 1004 at 32.48 s). The selectors refuse such grasps,
by the same solids the simulator's world checks for contacts."""

from __future__ import annotations

import numpy as np
import pytest

from pegbt.behaviours.actions.handover import handed
from pegbt.behaviours.resources.skills import Skills
from pegbt.motion.ik import solve_ik
from pegbt.motion.peg_clearance import tool_peg_gap
from pegbt.perception.blocks import BlockEstimate
from pegbt.perception.grasp import YAW_WINDOW, Grasp, grasp_options
from pegbt.sim.tools import ToolState
from pegbt.sim.world import World

# where the slips dropped the blocks (board frame, m; yaw, rad), as the re-picks' looks located them, and
# the arm that re-picked each to hand it over
DROPPED = [
    ("PSM2", (0.05547, 0.03004), -0.71995),
    ("PSM2", (0.02472, 0.04634), -0.88565),
    ("PSM1", (0.05097, 0.02310), 0.54340),
]


def _dropped(skills: Skills, xy: tuple[float, float], yaw: float) -> BlockEstimate:
    position = np.array([xy[0], xy[1], skills.cell.board.surface_z])
    return BlockEstimate(position, yaw, None, 1.0, 3e-4, 1000, True, "")


def _gap(skills: Skills, arm: str, pose: np.ndarray) -> float:
    q = solve_ik(pose, skills.arm(arm).settings)
    return float(tool_peg_gap(q, skills.cell.arm_to_board(arm), skills.cell))


@pytest.mark.parametrize(("arm", "xy", "yaw"), DROPPED)
def test_a_block_dropped_beside_a_peg_is_never_gripped_with_the_tool_on_that_peg(arm, xy, yaw):
    skills = Skills("optimized", variant="handover")
    block = _dropped(skills, xy, yaw)
    receiver = "PSM1" if arm == "PSM2" else "PSM2"
    for acceptable in (None, lambda option: handed(skills, arm, receiver, block, option)):
        grasp = skills.selectors[arm].pick(block, acceptable=acceptable)
        assert grasp is None or _gap(skills, arm, grasp.pose) >= 0.0
    plain = skills.selectors[arm].pick(block)
    assert plain is not None  # one of its sides is clear


def test_the_tool_peg_gap_misses_no_contact_the_simulators_world_counts():
    """Conservative: the world counts a contact where the solids' bounding boxes overlap too (a peg's box
    starts at its top), the gap treats the peg's top as rounded by its radius."""
    skills = Skills("optimized", variant="handover")
    world = World(seed=1)
    touching = 0
    for arm, xy, yaw in DROPPED:
        block = _dropped(skills, xy, yaw)
        for option in _within_reach(skills, arm, block):
            q = solve_ik(option.pose, skills.arm(arm).settings)
            gap = float(tool_peg_gap(q, skills.cell.arm_to_board(arm), skills.cell))
            tool = ToolState.from_joints(q, 0.5, skills.cell.arm_to_board(arm))
            if world._pegs_touched(tool.boxes(skills.cell.tool)):
                assert gap < 0.0, (arm, option.candidate, gap)
                touching += 1
            else:
                assert gap > -0.001, (arm, option.candidate, gap)
    assert touching >= 3


def _within_reach(skills: Skills, arm: str, block: BlockEstimate) -> list[Grasp]:
    """The grasps of `block` inside the arm's yaw window, clear of the pegs or not."""
    return [option for option in grasp_options(block.pose, arm, skills.cell) if abs(option.yaw) <= YAW_WINDOW]
