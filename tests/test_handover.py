"""Handover between the two arms on the reference setup: poses, phases and tool clearance."""

import numpy as np
import pytest

from pegbt.errors import PegbtError
from pegbt.motion.checks import trajectory_problems
from pegbt.motion.handover import handover_meeting_point, plan_handover, tool_distance
from pegbt.motion.ik import solve_ik
from pegbt.motion.kinematics import forward_kinematics
from pegbt.motion.limits import arm_settings
from pegbt.motion.waypoints import transfer_waypoints
from pegbt.workcell import workcell

PSM1, PSM2 = arm_settings("PSM1"), arm_settings("PSM2")
CELL = workcell()


def _lifted(arm, settings, peg):
    tops = CELL.peg_tops_in(arm)
    return solve_ik(transfer_waypoints(tops[peg], tops[peg], up=CELL.up_in(arm)).poses[1], settings)


def _plan(receiver_offset):
    meet = handover_meeting_point(CELL.pegs.tops[[3, 6, 9]])
    return meet, plan_handover(
        PSM2, PSM1, _lifted("PSM2", PSM2, 1), _lifted("PSM1", PSM1, 7), meet,
        CELL.board_to_arm("PSM2"), CELL.board_to_arm("PSM1"), receiver_offset,
    )


def _tip_in_board(arm, q):
    board_from_arm = np.linalg.inv(CELL.board_to_arm(arm))
    return board_from_arm[:3, :3] @ forward_kinematics(q)[:3, 3] + board_from_arm[:3, 3]


def test_handover_brings_both_tools_to_the_block_in_order():
    meet, plan = _plan([0.0087, 0.0, 0.0])
    assert [p.name for p in plan.phases] == ["meet", "receiver descends", "giver releases", "giver rises"]
    first, descend, release, rise = plan.phases
    assert np.allclose(_tip_in_board("PSM2", first.moves["PSM2"].q[-1]), meet, atol=1e-9)
    waiting = _tip_in_board("PSM1", first.moves["PSM1"].q[-1])
    grasped = _tip_in_board("PSM1", descend.moves["PSM1"].q[-1])
    assert np.allclose(grasped, meet + [0.0087, 0.0, 0.0], atol=1e-9)
    assert np.allclose(waiting - grasped, [0.0, 0.0, -0.013], atol=1e-9)  # 13 mm above (board z is down)
    assert descend.jaws == {"PSM1": pytest.approx(-0.2618)} and release.jaws == {"PSM2": pytest.approx(0.8727)}
    assert np.allclose(_tip_in_board("PSM2", rise.moves["PSM2"].q[-1]) - meet, [0.0, 0.0, -0.010], atol=1e-9)
    for phase in plan.phases:
        for arm, trajectory in phase.moves.items():
            assert trajectory_problems(trajectory, arm_settings(arm)) == []
    assert 0.005 <= plan.closest_tools <= 0.0087 + 1e-6


def test_tools_too_close_are_refused_naming_the_phase():
    with pytest.raises(PegbtError, match=r"tools come within .* mm of each other during 'receiver descends'"):
        _plan([0.002, 0.0, 0.0])


def test_tool_distance_is_symmetric_and_zero_for_the_same_tool():
    q = _lifted("PSM1", PSM1, 7)
    T = CELL.board_to_arm("PSM1")
    assert tool_distance(q, T, q, T) == pytest.approx(0.0, abs=1e-12)
    q2, T2 = _lifted("PSM2", PSM2, 1), CELL.board_to_arm("PSM2")
    assert tool_distance(q, T, q2, T2) == pytest.approx(tool_distance(q2, T2, q, T))
    assert tool_distance(q, T, q2, T2) > 0.02  # above pegs 7 and 1, about 35 mm apart
