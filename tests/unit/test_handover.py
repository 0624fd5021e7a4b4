"""Handover between the two arms on the reference setup: poses, phases and tool clearance."""

import numpy as np
import pytest

from pegbt.errors import PegbtError
from pegbt.motion.checks import trajectory_problems
from pegbt.motion.handover import handover_meeting_point, plan_handover, tool_distance
from pegbt.motion.ik import solve_ik
from pegbt.motion.kinematics import forward_kinematics
from pegbt.motion.limits import arm_settings
from pegbt.motion.transfer import TransferPlanner
from pegbt.motion.waypoints import transfer_waypoints
from pegbt.workcell import workcell

PSM1, PSM2 = arm_settings("PSM1"), arm_settings("PSM2")
RECEIVER = TransferPlanner(PSM1)
PLACE_PEG = 7
CELL = workcell()


def _lifted(arm, settings, peg):
    tops = CELL.peg_tops_in(arm)
    return solve_ik(transfer_waypoints(tops[peg], tops[peg], up=CELL.up_in(arm)).poses[1], settings)


def _plan(receiver_offset):
    meet = handover_meeting_point(CELL)
    return meet, plan_handover(
        PSM2,
        RECEIVER,
        _lifted("PSM2", PSM2, 1),
        _lifted("PSM1", PSM1, 7),
        meet,
        CELL.board_to_arm("PSM2"),
        CELL.board_to_arm("PSM1"),
        receiver_offset,
        CELL.pegs.top(PLACE_PEG),
    )


def _tip_in_board(arm, q):
    board_from_arm = CELL.arm_to_board(arm)
    return board_from_arm[:3, :3] @ forward_kinematics(q)[:3, 3] + board_from_arm[:3, 3]


def test_handover_brings_both_tools_to_the_block_in_order():
    meet, plan = _plan([0.0087, 0.0, 0.0])
    assert [p.name for p in plan.phases] == [
        "meet",
        "receiver descends",
        "giver releases",
        "giver rises",
        "receiver places",
    ]
    first, descend, release, rise, place = plan.phases
    assert np.allclose(_tip_in_board("PSM2", first.moves["PSM2"].q[-1]), meet, atol=1e-9)
    waiting = _tip_in_board("PSM1", first.moves["PSM1"].q[-1])
    grasped = _tip_in_board("PSM1", descend.moves["PSM1"].q[-1])
    assert np.allclose(grasped, meet + [0.0087, 0.0, 0.0], atol=1e-9)
    assert np.allclose(waiting - grasped, [0.0, 0.0, -0.013], atol=1e-9)  # 13 mm above (board z is down)
    assert descend.jaws == {"PSM1": pytest.approx(-0.2618)} and release.jaws == {
        "PSM2": pytest.approx(0.8727)
    }
    assert np.allclose(_tip_in_board("PSM2", rise.moves["PSM2"].q[-1]) - meet, [0.0, 0.0, -0.010], atol=1e-9)
    assert np.allclose(place.moves["PSM1"].q[0], descend.moves["PSM1"].q[-1], atol=1e-9)
    assert place.jaws == {"PSM1": pytest.approx(0.8727)}
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


def test_receiver_lowers_the_block_onto_its_peg_along_the_axis_clear_of_the_giver():
    cell = CELL
    _, plan = _plan([0.0087, 0.0, 0.0])
    place = plan.phases[-1].moves["PSM1"]
    T = cell.board_to_arm("PSM1")
    up = T[:3, :3] @ np.array([0.0, 0.0, -1.0])
    peg = T[:3, :3] @ cell.pegs.top(PLACE_PEG) + T[:3, 3]
    poses = forward_kinematics(place.q)
    tips = poses[:, :3, 3]
    # Ends on the peg at the drop height, at rest, within every limit.
    assert np.allclose(tips[-1], peg + 0.007 * up, atol=1e-9)
    assert np.abs(place.qd[-1]).max() < 1e-9 and trajectory_problems(place, PSM1) == []
    # Lowered along the peg's axis: while the block (10.2 mm below the tip) is on the peg, the tip is
    # within 0.5 mm of the axis; the tool stays within 2° of upright all the way.
    height = (tips - peg) @ up
    axis_distance = np.linalg.norm((tips - peg) - np.outer(height, up), axis=1)
    entered = int(np.flatnonzero(height >= 0.013)[-1]) + 1
    assert entered < len(place) - 5
    assert axis_distance[entered:].max() <= 0.0005
    assert np.degrees(np.arccos(np.clip(poses[:, :3, 2] @ up, -1.0, 1.0))).max() <= 2.0 + 1e-6
    # The giver holds its retreat pose meanwhile; the tools stay at least 5 mm apart.
    giver_still = plan.phases[3].moves["PSM2"].q[-1]
    apart = tool_distance(
        np.repeat(giver_still[None], len(place), axis=0), CELL.board_to_arm("PSM2"), place.q, T
    )
    assert apart.min() >= 0.005 and plan.closest_tools <= apart.min() + 1e-12
