"""With a planner, an approach from high up (the arm parked) is one SQP-planned motion over the pegs, quicker
than the rest-to-rest cubics through the transfer height that it was before, and it keeps the tool clear of
the peg tops; a handover's giver, risen from the meeting point, passes over them lower, and leaving the
block it handed over goes on into its next approach in one motion."""

from __future__ import annotations

import math

import numpy as np

from pegbt.behaviours.motion import planned_approach, rise
from pegbt.behaviours.poses import EXIT_WIDENING, to_arm, tool_pose
from pegbt.behaviours.resources.skills import Skills
from pegbt.frames import rigid_transform
from pegbt.motion.handover import handover_meeting_point
from pegbt.motion.ik import solve_ik
from pegbt.motion.kinematics import forward_kinematics
from pegbt.motion.waypoints import tool_down_rotation
from pegbt.perception.blocks import BlockEstimate

PEG = 1


def _parked(skills: Skills) -> np.ndarray:
    settings, cell = skills.arm("PSM1").settings, skills.cell
    return solve_ik(rigid_transform(tool_down_rotation(0.0, cell.up_in("PSM1")), settings.home_tip), settings)


def _block(skills: Skills, peg: int) -> BlockEstimate:
    top = skills.cell.pegs.positions[peg]
    return BlockEstimate(
        np.array([top[0], top[1], skills.cell.board.surface_z]),
        math.radians(10.0),
        peg,
        1.0,
        3e-4,
        1000,
        True,
        "",
    )


def _approach(condition: str):
    skills = Skills(condition)
    block = _block(skills, PEG)
    grasp = skills.selectors["PSM1"].pick(block)
    assert grasp is not None
    start = _parked(skills)
    return skills, grasp, planned_approach(skills, "PSM1", start, None, block, grasp)


def test_an_approach_from_high_up_is_one_motion_quicker_than_the_cubics_and_clear_of_the_peg_tops():
    skills, grasp, optimised = _approach("optimized")
    _, _, cubics = _approach("uncalibrated")
    assert np.allclose(forward_kinematics(optimised.q[-1]), grasp.pose, atol=1e-4)
    assert optimised.duration < cubics.duration - 0.3
    cell = skills.cell
    tips = forward_kinematics(optimised.q)[:, :3, 3]
    above = (tips - cell.peg_tops_in("PSM1")[0]) @ cell.up_in("PSM1")
    grasp_tip = grasp.pose[:3, 3]
    off_axis = np.linalg.norm(np.cross(tips - grasp_tip, cell.up_in("PSM1")), axis=1)
    # below the peg tops only on the block's axis (the final descent onto it)
    assert off_axis[above < 0.0].max() <= skills.motion.transfer.channel_tolerance + 1e-6


def test_a_givers_approach_from_the_meeting_point_over_the_pegs_as_low_as_a_carry_is_never_slower():
    skills = Skills("optimized")
    cell, arm = skills.cell, "PSM2"
    risen = tool_pose(to_arm(cell, arm, handover_meeting_point(cell, skills.motion)), 0.0, cell.up_in(arm))
    risen[:3, 3] += 0.007 * cell.up_in(arm)  # the giver's rise after letting go
    start = solve_ik(risen, skills.arm(arm).settings)
    quicker = 0
    for peg in (1, 3, 0):
        block = _block(skills, peg)
        grasp = skills.selectors[arm].pick(block)
        assert grasp is not None
        giver = planned_approach(skills, arm, start, None, block, grasp, giving=True)
        other = planned_approach(skills, arm, start, None, block, grasp)
        assert np.allclose(forward_kinematics(giver.q[-1]), grasp.pose, atol=1e-4)
        assert giver.duration <= other.duration + 1e-9
        quicker += giver.duration < other.duration - 0.02
    assert quicker >= 1


def test_a_givers_way_out_of_the_block_it_handed_over_into_its_next_approach_beats_rising_first():
    """From the meeting point, its jaw in the hole of the block the receiver now holds, the giver leaves
    along the block's axis until 7 mm up (its grip 4.5 mm below the top, 2.5 mm clear; off it only as the
    funnel widens over the top) and goes on over the pegs in the same motion: quicker than the rise to 7 mm
    up followed by the approach from there."""
    skills = Skills("optimized")
    cell, arm = skills.cell, "PSM2"
    motion, up = skills.arm(arm), cell.up_in(arm)
    meeting = tool_pose(to_arm(cell, arm, handover_meeting_point(cell, skills.motion)), 0.0, up)
    start = solve_ik(meeting, motion.settings)
    saved = []
    for peg in (1, 3, 0):
        block = _block(skills, peg)
        grasp = skills.selectors[arm].pick(block)
        assert grasp is not None
        risen = rise(cell, motion, arm, start, 0.007)
        after = planned_approach(skills, arm, risen.q[-1], None, block, grasp, giving=True)
        way = planned_approach(skills, arm, start, None, block, grasp, giving=True, out_of=0.007)
        assert np.allclose(forward_kinematics(way.q[-1]), grasp.pose, atol=1e-4)
        tips = forward_kinematics(way.q)[:, :3, 3]
        height = (tips - meeting[:3, 3]) @ up
        out = int(np.argmax(height >= 0.007 - 1e-9))
        off_axis = np.linalg.norm(np.cross(tips[:out] - meeting[:3, 3], up), axis=1)
        transfer = skills.motion.transfer
        widens_from = transfer.grasp_depth + cell.tool.jaw_radius + transfer.channel_tolerance
        funnel = transfer.channel_tolerance + EXIT_WIDENING * np.maximum(height[:out] - widens_from, 0.0)
        assert np.all(off_axis <= funnel + 1e-9)
        saved.append(risen.duration + after.duration - way.duration)
    assert min(saved) > 0.02, saved
    assert motion.fallbacks == 0


def test_with_the_other_arm_parked_an_approach_passes_lower_never_slower_and_on_the_axis_below_the_pegs():
    """Unilateral's second half: from letting go over a left-group peg to the block on a right-group peg,
    the approach's warm start passes 2 mm over the descent's channel top, not 7 (bilateral's, whose other
    arm may rest over the pegs): no slower for any, quicker for some, and as clear of the peg tops."""
    alone, shared = Skills("optimized", variant="unilateral"), Skills("optimized", variant="bilateral")
    cell, arm = alone.cell, "PSM1"
    up = cell.up_in(arm)
    quicker = 0
    for dropped, peg in ((1, 6), (3, 9), (5, 10)):
        over = cell.peg_tops_in(arm)[dropped] + alone.motion.transfer.drop_height_above_peg_top * up
        start = solve_ik(tool_pose(over, 0.0, up), alone.arm(arm).settings)
        block = _block(alone, peg)
        grasp = alone.selectors[arm].pick(block)
        assert grasp is not None
        low = planned_approach(alone, arm, start, None, block, grasp)
        high = planned_approach(shared, arm, start, None, block, grasp)
        assert np.allclose(forward_kinematics(low.q[-1]), grasp.pose, atol=1e-4)
        assert low.duration <= high.duration + 1e-9
        quicker += low.duration < high.duration - 0.02
        tips = forward_kinematics(low.q)[:, :3, 3]
        above = (tips - cell.peg_tops_in(arm)[0]) @ up
        off_axis = np.linalg.norm(np.cross(tips - grasp.pose[:3, 3], up), axis=1)
        assert off_axis[above < 0.0].max() <= alone.motion.transfer.channel_tolerance + 1e-6
    assert quicker >= 1
    assert alone.arm(arm).fallbacks == 0
