"""A handover's receiver, having let go of the block it placed, goes to wait above its next grasp at the
meeting point in one planned motion (`way_to_wait`, `out_to_wait`): quicker than the rest-to-rest moves
that stopped straight above its goal peg first, never lower than where it let go, on the pegs' axis until
its jaw's tips clear the peg top (then within the funnel), above its waiting pose in transit and down onto
it along its axis."""

from __future__ import annotations

import math

import numpy as np
import pytest

from pegbt.behaviours.actions.handover import way_to_wait
from pegbt.behaviours.meeting import plan_meeting
from pegbt.behaviours.motion import above_pegs_first
from pegbt.behaviours.poses import EXIT_WIDENING, WAIT_ARRIVAL, tool_pose
from pegbt.behaviours.resources.skills import Skills
from pegbt.motion.ik import solve_ik
from pegbt.motion.kinematics import forward_kinematics
from pegbt.perception.blocks import BlockEstimate

GIVER, RECEIVER = "PSM1", "PSM2"


def _receiver_grasp(skills: Skills):
    top = skills.cell.pegs.positions[
        7
    ]  # the second half: PSM1 picks from the right group, PSM2 places on the left
    block = BlockEstimate(
        np.array([top[0], top[1], skills.cell.board.surface_z]),
        math.radians(10.0),
        3,
        1.0,
        3e-4,
        1000,
        True,
        "",
    )
    grasp = skills.selectors[GIVER].pick(block)
    assert grasp is not None
    meeting = plan_meeting(skills, GIVER, RECEIVER, grasp, block)
    assert meeting is not None
    return meeting.receiver_grasp


@pytest.mark.parametrize("placed", [1, 0, 3])
def test_the_receivers_way_to_wait_from_its_goal_peg_is_one_motion_quicker_than_stopping_above_it(placed):
    skills = Skills("optimized", variant="handover")
    cell, motion = skills.cell, skills.arm(RECEIVER)
    up, transfer = cell.up_in(RECEIVER), skills.motion.transfer
    peg_top = cell.peg_tops_in(RECEIVER)[placed]
    start_tip = peg_top + transfer.drop_height_above_peg_top * up  # where its jaw let the block drop
    start = solve_ik(tool_pose(start_tip, 0.0, up), motion.settings)
    grasp = _receiver_grasp(skills)
    wait = grasp.pose[:3, 3] + skills.motion.handover.receiver_wait_above * up

    way = way_to_wait(skills, motion, RECEIVER, start, grasp)
    stops = above_pegs_first(cell, skills.motion, RECEIVER, start, motion.settings)
    assert stops  # low among the pegs: the rest-to-rest way stopped straight above first
    waiting = grasp.pose.copy()
    waiting[:3, 3] = wait
    stopping = motion.quickest(start, [*stops, solve_ik(waiting, motion.settings)], ["above", "waiting"])
    assert way.duration < stopping.duration - 0.1
    assert motion.fallbacks == 0
    assert np.allclose(forward_kinematics(way.q[-1])[:3, 3], wait, atol=1e-4)
    moving = np.linalg.norm(way.qd[1:-1], axis=1)
    assert moving.min() > 1e-3  # never at rest on the way

    tips = forward_kinematics(way.q)[:, :3, 3]
    height = (tips - start_tip) @ up
    assert height.min() >= -1e-5
    rise_to = float((wait - start_tip) @ up) + WAIT_ARRIVAL
    out = int(np.argmax(height >= rise_to - 1e-6))
    off_axis = np.linalg.norm(np.cross(tips[:out] - start_tip, up), axis=1)
    depth = -transfer.drop_height_above_peg_top
    funnel = transfer.channel_tolerance + EXIT_WIDENING * np.maximum(
        height[:out] - max(depth + cell.tool.jaw_radius + transfer.channel_tolerance, 0.0), 0.0
    )
    assert np.all(off_axis <= funnel + 1e-6)
    over_wait = (tips - wait) @ up
    arriving = int(len(tips) - 1 - np.argmax(over_wait[::-1] >= WAIT_ARRIVAL - 1e-6))
    assert over_wait[out:arriving].min() >= WAIT_ARRIVAL - 2e-4
    beside = np.linalg.norm(np.cross(tips[arriving + 1 :] - wait, up), axis=1)
    assert beside.max() <= transfer.channel_tolerance + 1e-5
